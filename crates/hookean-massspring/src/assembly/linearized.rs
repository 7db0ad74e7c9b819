//! The tutorial's constant linearised Jacobians (eq. 50), in block and in
//! isotropic storage.

use hookean_sparse::block::{self, Block3};
use hookean_sparse::{IsoBlockMatrix, SymBlockMatrix};

use crate::model::{MassSpringModel, SpringDamping};

use super::*;

impl MassSpringModel {
    /// Writes the tutorial's constant linearised Jacobians (eq. 50): per
    /// spring an isotropic block `k I` in `df/dx` (`-k I` on the diagonals)
    /// and `d I` in `df/dv` (for projected or incorrect damping; none for
    /// [`SpringDamping::None`]), plus `-c I` for air friction. They depend on
    /// the material only (not on the state, nor on contacts); permanent
    /// constraints (pins, sliding) are applied as `P_i B P_j`. The paper's
    /// `k_ij / l_ij^2` is our `k` (N/m).
    pub fn assemble_linearized(&self, dfdx: &mut SymBlockMatrix, dfdv: &mut SymBlockMatrix) {
        dfdx.set_zero();
        dfdv.set_zero();
        for (s, sl) in self.springs.iter().zip(&self.plan.slots) {
            let (i, j) = (s.i, s.j);
            let kb = block::scale(&block::IDENTITY, s.stiffness);
            let d = match self.options.damping {
                SpringDamping::None => 0.0,
                _ => s.damping,
            };
            let db = block::scale(&block::IDENTITY, d);
            self.scatter_permanent(dfdx, sl, i, j, &kb);
            if d != 0.0 {
                self.scatter_permanent(dfdv, sl, i, j, &db);
            }
        }
        let c = self.options.air_friction;
        if c != 0.0 {
            for p in 0..self.n_particles() {
                let pp = self.fixes[p].projector();
                dfdv.add_to_slot(self.plan.diag_slots[p], &block::scale(&pp, -c));
            }
        }
    }

    /// The tutorial's eq. 50 in isotropic storage, one scalar per block:
    /// `k` per spring in `df/dx` (`-k` on the diagonals), `d` in `df/dv`
    /// (none for [`SpringDamping::None`]), `-c` on the diagonal for air
    /// friction. Permanent constraints are *not* applied (they would make
    /// the blocks anisotropic): the integrators filter the constrained
    /// directions (filtered PCG, or the eliminated pins of the IMEX
    /// factorisation). Allocates nothing; panics if the matrices are not on
    /// the model's pattern.
    pub fn assemble_linearized_iso(&self, dfdx: &mut IsoBlockMatrix, dfdv: &mut IsoBlockMatrix) {
        dfdx.set_zero();
        dfdv.set_zero();
        let damped = self.options.damping != SpringDamping::None;
        for s in &self.springs {
            let (i, j) = (s.i, s.j);
            let slots = (dfdx.slot(i, j), dfdx.slot(i, i), dfdx.slot(j, j));
            let (Ok(ij), Ok(ii), Ok(jj)) = slots else {
                panic!("linearised Jacobian not on the model's pattern");
            };
            dfdx.add_to_slot(ij, s.stiffness);
            dfdx.add_to_slot(ii, -s.stiffness);
            dfdx.add_to_slot(jj, -s.stiffness);
            if damped && s.damping != 0.0 {
                dfdv.add_to_slot(ij, s.damping);
                dfdv.add_to_slot(ii, -s.damping);
                dfdv.add_to_slot(jj, -s.damping);
            }
        }
        let c = self.options.air_friction;
        if c != 0.0 {
            for p in 0..self.n_particles() {
                if let Ok(pp) = dfdv.slot(p, p) {
                    dfdv.add_to_slot(pp, -c);
                }
            }
        }
    }

    fn scatter_permanent(
        &self,
        m: &mut SymBlockMatrix,
        sl: &SpringSlots,
        i: usize,
        j: usize,
        b: &Block3,
    ) {
        if self.fixes[i].count > 0 || self.fixes[j].count > 0 {
            let pi = self.fixes[i].projector();
            let pj = self.fixes[j].projector();
            m.add_to_slot(sl.ij, &block::mul(&block::mul(&pi, b), &pj));
            m.add_to_slot(sl.ii, &neg(&block::mul(&block::mul(&pi, b), &pi)));
            m.add_to_slot(sl.jj, &neg(&block::mul(&block::mul(&pj, b), &pj)));
        } else {
            let nb = neg(b);
            m.add_to_slot(sl.ij, b);
            m.add_to_slot(sl.ii, &nb);
            m.add_to_slot(sl.jj, &nb);
        }
    }
}
