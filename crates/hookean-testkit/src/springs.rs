//! A small mass-spring model implementing [`SecondOrderProblem`]: a chain
//! of particles (a rope) with the spring law of docs/ARCHITECTURE.md, for integrator
//! tests and benches until `hookean-massspring` provides the real models.
//!
//! Spring `(i, j)`: `f_i = k (l - l0) u + d ((v_j - v_i) . u) u`,
//! `u = (x_j - x_i) / l`, `f_j = -f_i`; `K_ij = df_i/dx_j = k [max(0, 1 -
//! l0/l) (I - u u^T) + u u^T]` (definiteness-clamped), `df_i/dx_i = -sum_j
//! K_ij`; `D_ij = d u u^T` likewise (the damping force's dependence on `x`
//! is left out of `df/dx`, as in docs/ARCHITECTURE.md). Gravity pulls along `-z`.

use std::sync::Arc;

use hookean_problem::SecondOrderProblem;
use hookean_sparse::{Block3, BlockPattern, Constraints, Slot, SymBlockMatrix, block};

/// A chain of `n` particles along x joined by springs `(i, i+1)`; the
/// particles in `pinned` get zero velocity constraints in `begin_step`.
#[derive(Debug, Clone)]
pub struct SpringChain {
    /// Spring stiffness (N/m).
    pub k: f64,
    /// Spring damping (N s/m).
    pub d: f64,
    /// Rest length of each spring (m).
    pub l0: f64,
    /// Gravity (m/s^2, along -z).
    pub g: f64,
    /// Pinned particles (velocity constrained to zero).
    pub pinned: Vec<usize>,
    mass: Vec<f64>,
    pattern: Arc<BlockPattern>,
    slots: Vec<[Slot; 3]>,
}

impl SpringChain {
    /// `n >= 2` particles of mass `m` each.
    ///
    /// # Panics
    /// If `n < 2`.
    pub fn new(n: usize, m: f64, k: f64, d: f64, l0: f64, g: f64) -> Self {
        assert!(n >= 2, "a chain needs two particles");
        let pattern =
            Arc::new(BlockPattern::new(n, (0..n - 1).map(|i| (i, i + 1))).expect("valid pattern"));
        let probe = SymBlockMatrix::new(pattern.clone());
        let slots = (0..n - 1)
            .map(|i| {
                [
                    probe.slot(i, i).expect("diagonal"),
                    probe.slot(i + 1, i + 1).expect("diagonal"),
                    probe.slot(i, i + 1).expect("spring"),
                ]
            })
            .collect();
        Self {
            k,
            d,
            l0,
            g,
            pinned: Vec::new(),
            mass: vec![m; 3 * n],
            pattern,
            slots,
        }
    }

    /// Number of particles.
    pub fn n(&self) -> usize {
        self.mass.len() / 3
    }

    /// Positions along the x axis with spacing `stretch * l0`, and zero velocities.
    pub fn initial_state(&self, stretch: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.n();
        let mut x = vec![0.0; 3 * n];
        for i in 0..n {
            x[3 * i] = i as f64 * stretch * self.l0;
        }
        (x, vec![0.0; 3 * n])
    }

    fn spring(&self, x: &[f64], i: usize) -> ([f64; 3], f64) {
        let j = i + 1;
        let e = [
            x[3 * j] - x[3 * i],
            x[3 * j + 1] - x[3 * i + 1],
            x[3 * j + 2] - x[3 * i + 2],
        ];
        let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        ([e[0] / l, e[1] / l, e[2] / l], l)
    }
}

impl SecondOrderProblem for SpringChain {
    fn dim(&self) -> usize {
        self.mass.len()
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    fn force(&self, _t: f64, x: &[f64], v: &[f64], f: &mut [f64]) {
        for p in 0..self.n() {
            f[3 * p] = 0.0;
            f[3 * p + 1] = 0.0;
            f[3 * p + 2] = -self.mass[3 * p + 2] * self.g;
        }
        for i in 0..self.n() - 1 {
            let j = i + 1;
            let (u, l) = self.spring(x, i);
            let dv: f64 = (0..3).map(|c| (v[3 * j + c] - v[3 * i + c]) * u[c]).sum();
            let s = self.k * (l - self.l0) + self.d * dv;
            for c in 0..3 {
                f[3 * i + c] += s * u[c];
                f[3 * j + c] -= s * u[c];
            }
        }
    }

    fn jacobian_pattern(&self) -> Arc<BlockPattern> {
        self.pattern.clone()
    }

    fn force_jacobians(
        &self,
        _t: f64,
        x: &[f64],
        _v: &[f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    ) {
        dfdx.set_zero();
        dfdv.set_zero();
        for i in 0..self.n() - 1 {
            let (u, l) = self.spring(x, i);
            let uu: Block3 = block::outer(&u, &u);
            let c = (1.0 - self.l0 / l).max(0.0);
            let kij = block::add(
                &block::scale(
                    &block::add(&block::IDENTITY, &block::scale(&uu, -1.0)),
                    self.k * c,
                ),
                &block::scale(&uu, self.k),
            );
            let dij = block::scale(&uu, self.d);
            let [sii, sjj, sij] = self.slots[i];
            for (mat, b) in [(&mut *dfdx, kij), (&mut *dfdv, dij)] {
                let neg = block::scale(&b, -1.0);
                mat.add_to_slot(sii, &neg);
                mat.add_to_slot(sjj, &neg);
                mat.add_to_slot(sij, &b);
            }
        }
    }

    fn begin_step(
        &mut self,
        _t: f64,
        _x: &mut [f64],
        _v: &mut [f64],
        constraints: &mut Constraints,
    ) {
        for &p in &self.pinned {
            constraints
                .pin(p, [0.0; 3])
                .expect("pinned particle in range");
        }
    }
}
