//! Test helpers: random models, finite differences, dense matrices, and a
//! tiny linearised implicit-Euler stepper (the real integrators live in
//! hookean-ode; this one only drives the model in tests).

#![allow(dead_code)]

use hookean_massspring::{
    MassSpringModel, ModelOptions, SecondOrderProblem, Spring, SpringDamping, State,
};
use hookean_sparse::{
    BlockJacobi, CgParams, CgWorkspace, Constraints, PreconditionerSetup, SymBlockMatrix,
    filtered_pcg,
};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// A random model: `n` particles at random positions in the unit cube,
/// springs between all pairs (i, j) with i + 1 = j or (i + j) even, rest
/// lengths 0.5x-1.5x the current length (some compressed, some stretched),
/// random masses, stiffnesses and damping; random velocities.
pub fn random_model(
    n: usize,
    damping: SpringDamping,
    air: f64,
    seed: u64,
) -> (MassSpringModel, State) {
    let mut rng = SmallRng::seed_from_u64(seed);
    let x: Vec<f64> = (0..3 * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let v: Vec<f64> = (0..3 * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let masses: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..2.0)).collect();
    let mut springs = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            if j == i + 1 || (i + j) % 2 == 0 {
                let l = dist(&x, i, j);
                springs.push(Spring::new(
                    i,
                    j,
                    l * rng.random_range(0.5..1.5),
                    rng.random_range(10.0..100.0),
                    rng.random_range(0.5..2.0),
                ));
            }
        }
    }
    let options = ModelOptions {
        damping,
        air_friction: air,
        ..ModelOptions::default()
    };
    let model = MassSpringModel::new(masses, springs, options).unwrap();
    (model, State { x, v })
}

pub fn dist(x: &[f64], i: usize, j: usize) -> f64 {
    (0..3)
        .map(|r| (x[3 * j + r] - x[3 * i + r]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Central finite differences of `f` with respect to `x` (`wrt_x`) or `v`:
/// `J[:, k] = (f(.. + eps e_k) - f(.. - eps e_k)) / (2 eps)` for the columns
/// in `columns` (others left zero).
pub fn fd_jacobian(
    model: &MassSpringModel,
    x: &[f64],
    v: &[f64],
    wrt_x: bool,
    columns: &[usize],
) -> Vec<Vec<f64>> {
    let n = x.len();
    let eps = 1e-6;
    let mut jac = vec![vec![0.0; n]; n];
    let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
    for &k in columns {
        let (mut xp, mut vp) = (x.to_vec(), v.to_vec());
        let (mut xm, mut vm) = (x.to_vec(), v.to_vec());
        if wrt_x {
            xp[k] += eps;
            xm[k] -= eps;
        } else {
            vp[k] += eps;
            vm[k] -= eps;
        }
        model.force(0.0, &xp, &vp, &mut fp);
        model.force(0.0, &xm, &vm, &mut fm);
        for r in 0..n {
            jac[r][k] = (fp[r] - fm[r]) / (2.0 * eps);
        }
    }
    jac
}

pub fn dense_of_csr(a: &sprs::CsMat<f64>) -> Vec<Vec<f64>> {
    let (r, c) = a.shape();
    let mut d = vec![vec![0.0; c]; r];
    for (&val, (i, j)) in a.iter() {
        d[i][j] += val;
    }
    d
}

pub fn dense(a: &SymBlockMatrix) -> Vec<Vec<f64>> {
    dense_of_csr(&a.to_csr())
}

/// `max |a - b| / max |b|` (over all entries; `max |a - b|` when `b = 0`).
pub fn rel_err(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let mut diff = 0.0_f64;
    let mut scale = 0.0_f64;
    for (ra, rb) in a.iter().zip(b) {
        for (x, y) in ra.iter().zip(rb) {
            diff = diff.max((x - y).abs());
            scale = scale.max(y.abs());
        }
    }
    if scale == 0.0 { diff } else { diff / scale }
}

/// Smallest eigenvalue of a dense symmetric matrix, by faer's dense eigen solver.
pub fn min_eigenvalue(a: &[Vec<f64>]) -> f64 {
    let n = a.len();
    let m = faer::Mat::<f64>::from_fn(n, n, |i, j| a[i][j]);
    let ev = m
        .as_ref()
        .self_adjoint_eigenvalues(faer::Side::Lower)
        .unwrap();
    ev[0]
}

/// Reusable buffers of [`implicit_euler_step`].
pub struct Stepper {
    pub constraints: Constraints,
    pub sys: hookean_massspring::ImplicitSystem,
    pub ws: CgWorkspace,
    pub dv: Vec<f64>,
    pub t: f64,
}

impl Stepper {
    pub fn new(model: &MassSpringModel) -> Self {
        Self {
            constraints: Constraints::new(model.n_particles()),
            sys: model.implicit_system(),
            ws: CgWorkspace::new(model.dim()),
            dv: vec![0.0; model.dim()],
            t: 0.0,
        }
    }

    /// One linearised implicit-Euler step (Baraff-Witkin): `begin_step`,
    /// `A dv = b` by filtered PCG, `v += dv`, `x += h v`.
    pub fn step(&mut self, model: &mut MassSpringModel, s: &mut State, h: f64) {
        model.begin_step(self.t, &mut s.x, &mut s.v, &mut self.constraints);
        model
            .assemble_implicit_euler(h, &s.x, &s.v, &mut self.sys)
            .unwrap();
        let mut pre = BlockJacobi::new();
        pre.setup(&self.sys.a).unwrap();
        self.dv.fill(0.0);
        let params = CgParams {
            rtol: 1e-12,
            ..CgParams::default()
        };
        let info = filtered_pcg(
            &self.sys.a,
            &pre,
            &self.sys.b,
            &mut self.dv,
            &self.constraints,
            &params,
            &mut self.ws,
            None,
        )
        .unwrap();
        assert!(info.converged);
        for k in 0..s.v.len() {
            s.v[k] += self.dv[k];
            s.x[k] += h * s.v[k];
        }
        self.t += h;
    }
}

/// One symplectic (semi-implicit) Euler step using only `begin_step`,
/// `mass` and `force`, as an explicit integrator would.
pub fn symplectic_euler_step(
    model: &mut MassSpringModel,
    s: &mut State,
    h: f64,
    constraints: &mut Constraints,
    f: &mut [f64],
) {
    model.begin_step(0.0, &mut s.x, &mut s.v, constraints);
    model.force(0.0, &s.x, &s.v, f);
    let m = model.mass().to_vec();
    for k in 0..s.v.len() {
        s.v[k] += h * f[k] / m[k];
        s.x[k] += h * s.v[k];
    }
}
