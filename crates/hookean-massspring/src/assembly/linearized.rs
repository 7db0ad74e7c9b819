//! The tutorial's constant linearised Jacobians (eq. 50), in block and in
//! isotropic storage.

use hookean_sparse::block::{self, Block3};
use hookean_sparse::{IsoBlockMatrix, SymBlockMatrix};

use crate::model::{MassSpringModel, SpringDamping};

use super::*;

impl MassSpringModel {
    /// Whether eq. 50's constant Jacobians describe the model: not with
    /// wind, whose drag and lift `df/dv` turns with each triangle's normal
    /// and grows with its speed relative to the air (`wind.rs`), so that no
    /// constant matrix is near it. Without it a stiff drag (`h |df/dv| / m`
    /// of order 1 or more) leaves simplified Newton a fixed-point iteration
    /// on the drag, which diverges; the integrators then fall back to the
    /// true Jacobian, kept from the step's start (simplified Newton).
    pub fn has_constant_linearization(&self) -> bool {
        self.wind.is_none()
    }

    /// Writes the tutorial's constant linearised Jacobians (eq. 50): per
    /// spring an isotropic block `k I` in `df/dx` (`-k I` on the diagonals)
    /// and `d I` in `df/dv` (for projected or incorrect damping; none for
    /// [`SpringDamping::None`]), plus `-c I` for air friction and `-w k I`
    /// in `df/dx` for each held soft pin (its exact Jacobian, a zero-rest
    /// spring's). They depend on the material only (not on the state, nor
    /// on contacts; a pin group's release bumps the material revision); permanent
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
        for s in &self.soft_pins {
            let pp = self.fixes[s.p].projector();
            dfdx.add_to_slot(self.plan.diag_slots[s.p], &block::scale(&pp, -s.k));
        }
    }

    /// The tutorial's eq. 50 in isotropic storage, one scalar per block:
    /// `k` per spring in `df/dx` (`-k` on the diagonals), `d` in `df/dv`
    /// (none for [`SpringDamping::None`]), `-c` on the diagonal for air
    /// friction, `-w k` on it for each held soft pin. Permanent constraints are *not* applied (they would make
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
        for s in &self.soft_pins {
            if let Ok(pp) = dfdx.slot(s.p, s.p) {
                dfdx.add_to_slot(pp, -s.k);
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
