//! One implicit Euler step of the reference drape scene (docs/ARCHITECTURE.md) as a
//! nonlinear system in the reduced velocity form, shared by the cloth
//! tests, the `cloth_bars` example and the `newton_cloth` bench:
//!
//! `G(dv) = P (M dv - h f(x0 + h (v0 + dv), v0 + dv))`,
//! `J = M - h df/dv - h^2 df/dx` (SPD with the clamped stiffness),
//!
//! with `P` the filter of the two pinned corners. The approximate Jacobian
//! is the tutorial's eq. (50): isotropic blocks `k I` and `d I`.

#![allow(dead_code)]

use std::sync::Arc;

use hookean_nonlinear::{NonlinearError, NonlinearSystem};
use hookean_sparse::{BlockPattern, Constraints, SymBlockMatrix};
use hookean_testkit::cloth::{
    GridSpring, add_linearized_jacobians, add_spring_forces, add_spring_jacobians, grid_positions,
    grid_springs, spring_pattern,
};

/// Gravity (m/s^2), along -z.
pub const GRAVITY: f64 = 9.81;

/// The step's data and work buffers.
pub struct ClothStep {
    pub n: usize,
    pub springs: Vec<GridSpring>,
    pub d: f64,
    pub h: f64,
    pub mass: Vec<f64>,
    pub x0: Vec<f64>,
    pub v0: Vec<f64>,
    pub constraints: Constraints,
    /// Clamp `max(0, 1 - l0/l)` in the stiffness blocks (SPD) or not.
    pub clamp: bool,
    pub pattern: Arc<BlockPattern>,
    dfdx: SymBlockMatrix,
    dfdv: SymBlockMatrix,
    xt: Vec<f64>,
    vt: Vec<f64>,
    f: Vec<f64>,
}

impl ClothStep {
    /// `n x n` particles, stiffness `k` (bend `k/10`), damping `d`, step `h`;
    /// the cloth starts at rest from a flat grid displaced by `jitter` grid
    /// spacings (so springs are stretched and compressed), two corners pinned.
    pub fn new(n: usize, k: f64, d: f64, h: f64, jitter: f64, seed: u64) -> Self {
        let springs = grid_springs(n, k);
        let np = n * n;
        let pattern = spring_pattern(np, &springs);
        let mut constraints = Constraints::new(np);
        constraints.pin(0, [0.0; 3]).unwrap();
        constraints.pin(n - 1, [0.0; 3]).unwrap();
        Self {
            n,
            springs,
            d,
            h,
            mass: vec![1.0 / np as f64; 3 * np],
            x0: grid_positions(n, jitter, seed),
            v0: vec![0.0; 3 * np],
            constraints,
            clamp: true,
            dfdx: SymBlockMatrix::new(pattern.clone()),
            dfdv: SymBlockMatrix::new(pattern.clone()),
            pattern,
            xt: vec![0.0; 3 * np],
            vt: vec![0.0; 3 * np],
            f: vec![0.0; 3 * np],
        }
    }

    /// Storage for the Jacobian (on the springs' pattern).
    pub fn jacobian_storage(&self) -> SymBlockMatrix {
        SymBlockMatrix::new(self.pattern.clone())
    }

    /// The constraints with zero values, for the PCG solver of the corrections.
    pub fn correction_constraints(&self) -> Constraints {
        self.constraints.clone()
    }

    fn state(&mut self, dv: &[f64]) {
        for i in 0..dv.len() {
            self.vt[i] = self.v0[i] + dv[i];
            self.xt[i] = self.x0[i] + self.h * self.vt[i];
        }
    }

    /// `J = M - h D - h^2 K` from the matrices in `dfdx`, `dfdv`.
    fn combine(&self, jac: &mut SymBlockMatrix) -> Result<(), NonlinearError> {
        let h = self.h;
        jac.assign_diagonal_plus_combination(&self.mass, -h * h, &self.dfdx, -h, &self.dfdv)?;
        Ok(())
    }
}

impl NonlinearSystem for ClothStep {
    type Jacobian = SymBlockMatrix;

    fn dim(&self) -> usize {
        3 * self.n * self.n
    }

    fn residual(&mut self, dv: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.state(dv);
        for (p, f) in self.f.chunks_exact_mut(3).enumerate() {
            f[0] = 0.0;
            f[1] = 0.0;
            f[2] = -GRAVITY * self.mass[3 * p + 2];
        }
        add_spring_forces(&self.springs, self.d, &self.xt, &self.vt, &mut self.f);
        for i in 0..g.len() {
            g[i] = self.mass[i] * dv[i] - self.h * self.f[i];
        }
        self.constraints.project(g);
        Ok(())
    }

    fn jacobian(&mut self, dv: &[f64], jac: &mut SymBlockMatrix) -> Result<(), NonlinearError> {
        self.state(dv);
        self.dfdx.set_zero();
        self.dfdv.set_zero();
        add_spring_jacobians(
            &self.springs,
            self.d,
            &self.xt,
            self.clamp,
            &mut self.dfdx,
            &mut self.dfdv,
        );
        self.combine(jac)
    }

    fn approximate_jacobian(
        &mut self,
        _dv: &[f64],
        jac: &mut SymBlockMatrix,
    ) -> Result<bool, NonlinearError> {
        self.dfdx.set_zero();
        self.dfdv.set_zero();
        add_linearized_jacobians(&self.springs, self.d, &mut self.dfdx, &mut self.dfdv);
        self.combine(jac)?;
        Ok(true)
    }
}

/// Scalar structural nonzeros of a symmetric block matrix (both triangles):
/// entries that are not exactly zero.
pub fn scalar_nonzeros(m: &SymBlockMatrix) -> usize {
    m.to_csr().iter().filter(|(v, _)| **v != 0.0).count()
}

/// The same step with the linearised Jacobian of eq. (50) stored with
/// isotropic blocks (one scalar per block): `jacobian` fills
/// `J = M - h D_lin - h^2 K_lin`, `J_ij = -(h d + h^2 k)` per spring.
pub struct LinearizedCloth<'a>(pub &'a mut ClothStep);

impl LinearizedCloth<'_> {
    /// Storage for the isotropic Jacobian.
    pub fn jacobian_storage(&self) -> hookean_sparse::IsoBlockMatrix {
        hookean_sparse::IsoBlockMatrix::new(self.0.pattern.clone())
    }
}

impl NonlinearSystem for LinearizedCloth<'_> {
    type Jacobian = hookean_sparse::IsoBlockMatrix;

    fn dim(&self) -> usize {
        self.0.dim()
    }

    fn residual(&mut self, dv: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.0.residual(dv, g)
    }

    fn jacobian(
        &mut self,
        _dv: &[f64],
        jac: &mut hookean_sparse::IsoBlockMatrix,
    ) -> Result<(), NonlinearError> {
        let s = &*self.0;
        jac.set_zero();
        for sp in &s.springs {
            let c = s.h * s.d + s.h * s.h * sp.k;
            jac.add_to_block(sp.i, sp.j, -c)?;
            jac.add_to_block(sp.i, sp.i, c)?;
            jac.add_to_block(sp.j, sp.j, c)?;
        }
        let m: Vec<f64> = s.mass.iter().step_by(3).copied().collect();
        jac.add_to_diagonal(&m)?;
        Ok(())
    }
}
