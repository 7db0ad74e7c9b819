//! The exact, generally non-symmetric `df/dx` as an `sprs` CSR matrix
//! (unclamped stiffness plus projected damping's position derivative `G`).

use hookean_sparse::block::{self, Block3};

use crate::error::MassSpringError;
use crate::model::{MassSpringModel, SpringDamping, point};

use super::*;

impl MassSpringModel {
    /// The exact, generally non-symmetric `df/dx` at `(x, v)` as a CSR
    /// matrix: unclamped stiffness blocks plus the full position derivative
    /// `G` of projected damping, projected for constrained particles
    /// (`P_i J_ij P_j`). For tests and for Newton variants where exactness
    /// matters; it allocates.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state).
    pub fn dfdx_exact(&self, x: &[f64], v: &[f64]) -> Result<sprs::CsMat<f64>, MassSpringError> {
        self.check_state(x, v)?;
        let n = self.n_particles();
        let mut tri = sprs::TriMat::new((3 * n, 3 * n));
        let mut put = |bi: usize, bj: usize, b: &Block3| {
            for r in 0..3 {
                for c in 0..3 {
                    if b[r][c] != 0.0 {
                        tri.add_triplet(3 * bi + r, 3 * bj + c, b[r][c]);
                    }
                }
            }
        };
        for s in &self.springs {
            let (i, j) = (s.i, s.j);
            let e = point(x, j) - point(x, i);
            let l = e.norm();
            let inv_l = 1.0 / l;
            let u = e * inv_l;
            let mut b = stiffness_block(s.stiffness, 1.0 - s.rest_length / l, &u);
            if self.options.damping == SpringDamping::Projected {
                let dv = point(v, j) - point(v, i);
                b = block::add(&b, &damping_position_block(s.damping, l, &u, &dv));
            }
            let (pi, pj) = (&self.active_set.proj[i], &self.active_set.proj[j]);
            put(i, j, &block::mul(&block::mul(pi, &b), pj));
            put(j, i, &block::mul(&block::mul(pj, &b), pi));
            put(i, i, &neg(&block::mul(&block::mul(pi, &b), pi)));
            put(j, j, &neg(&block::mul(&block::mul(pj, &b), pj)));
        }
        Ok(tri.to_csr())
    }
}
