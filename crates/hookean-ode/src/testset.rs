//! The standard stiff test problems, with analytic Jacobians and published
//! reference solutions, for tests, examples and the solver comparison
//! (`scripts/stiff-compare.sh`).
//!
//! - [`Robertson`]: chemical kinetics (Robertson 1966; Hairer-Wanner II,
//!   section IV.1), to `t = 40` and `t = 1e5`.
//! - [`VanDerPol`]: the relaxation oscillator with `mu = 1000` in the scaled
//!   form `eps = 1 / mu^2 = 1e-6` of the IVP test set (problem VDPOL).
//! - [`Hires`]: the plant-physiology model of the IVP test set (HIRES).
//! - [`Orego`]: the Oregonator (IVP test set, OREGO).
//! - [`E5`]: the pyrolysis problem of Enright-Hull's stiff DETEST (E5).
//! - [`SpringChain`]: a chain of 50 masses with alternating soft and stiff
//!   springs and Rayleigh damping (linear: its reference is the matrix
//!   exponential, [`SpringChain::exact`]), with a sparse Jacobian.
//!
//! The reference values of the IVP test set (F. Mazzia, C. Magherini,
//! "Test Set for IVP Solvers", release 2.4, 2008, problems HIRES, OREGO,
//! VDPOL, E5, computed with RADAU in extended precision) are quoted to 16
//! digits. Robertson at `t = 40` is Enright-Hull's DETEST problem D2 (also
//! Hairer-Wanner's figure IV.1.3 values `0.7158270687, 9.185534764e-6,
//! 0.2841637457`); at `t = 1e5` it is a Radau reference at `rtol = 1e-13`
//! that our solver reproduces at `rtol = 1e-11` (test `robertson_reference_1e5_is_reproduced`).

// The reference values are quoted with all the digits they were published with.
#![allow(clippy::excessive_precision)]

use hookean_problem::FirstOrderProblem;

use crate::options::SolverOptions;

/// A stiff test problem: the right-hand side with its Jacobian, the
/// initial value, the end time and the reference solution there.
pub trait TestProblem: FirstOrderProblem {
    /// The problem's name (as in the test set).
    fn name(&self) -> &'static str;
    /// The initial value at `t = 0`.
    fn y0(&self) -> Vec<f64>;
    /// The end time.
    fn t_end(&self) -> f64;
    /// The reference solution at [`t_end`](Self::t_end).
    fn reference(&self) -> Vec<f64>;
    /// The magnitude below which a component counts as negligible: the
    /// absolute tolerance is `rtol * floor` (per component), and errors
    /// are measured relative to `|y_ref| + floor` (the test set's mixed error).
    fn floor(&self) -> Vec<f64>;
}

/// The one set of default options used on the whole test set: only the
/// tolerances follow the problem, `atol_i = rtol * floor_i`.
pub fn options<P: TestProblem>(problem: &P, rtol: f64) -> SolverOptions {
    let atol: Vec<f64> = problem.floor().iter().map(|f| f * rtol).collect();
    SolverOptions::with_tolerances(rtol, atol)
}

/// The mixed relative error `max_i |y_i - ref_i| / (|ref_i| + floor_i)` of
/// a [`TestProblem`] solution at its end time.
pub fn mixed_error(y: &[f64], reference: &[f64], floor: &[f64]) -> f64 {
    y.iter()
        .zip(reference)
        .zip(floor)
        .map(|((a, r), f)| (a - r).abs() / (r.abs() + f))
        .fold(0.0, f64::max)
}

/// Robertson's chemical kinetics: `y1' = -0.04 y1 + 1e4 y2 y3`,
/// `y2' = 0.04 y1 - 1e4 y2 y3 - 3e7 y2^2`, `y3' = 3e7 y2^2`, `y(0) = (1, 0, 0)`.
#[derive(Debug, Clone, Copy)]
pub struct Robertson {
    /// The end time: 40 or 1e5.
    pub t_end: f64,
}

impl FirstOrderProblem for Robertson {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
        dy[2] = 3e7 * y[1] * y[1];
        dy[1] = -dy[0] - dy[2];
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
        j[0] = -0.04;
        j[1] = 1e4 * y[2];
        j[2] = 1e4 * y[1];
        j[6] = 0.0;
        j[7] = 6e7 * y[1];
        j[8] = 0.0;
        for c in 0..3 {
            j[3 + c] = -j[c] - j[6 + c];
        }
        true
    }
}

impl TestProblem for Robertson {
    fn name(&self) -> &'static str {
        if self.t_end > 1e3 {
            "robertson-1e5"
        } else {
            "robertson-40"
        }
    }
    fn y0(&self) -> Vec<f64> {
        vec![1.0, 0.0, 0.0]
    }
    fn t_end(&self) -> f64 {
        self.t_end
    }
    fn reference(&self) -> Vec<f64> {
        if self.t_end > 1e3 {
            vec![
                0.01786592114210887,
                7.274751468440222e-8,
                0.9821340061103758,
            ]
        } else {
            vec![0.7158270687193941, 9.185534764557338e-6, 0.2841637457458413]
        }
    }
    fn floor(&self) -> Vec<f64> {
        vec![1e-6, 1e-10, 1e-6]
    }
}

/// Van der Pol's oscillator `y1' = y2`, `y2' = ((1 - y1^2) y2 - y1) / eps`
/// with `eps = 1e-6` (`mu = 1000` in the time scale `t / mu`), `y(0) = (2, 0)`,
/// `t_end = 2` (IVP test set, VDPOL).
#[derive(Debug, Clone, Copy, Default)]
pub struct VanDerPol;

const VDP_EPS: f64 = 1e-6;

impl FirstOrderProblem for VanDerPol {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = ((1.0 - y[0] * y[0]) * y[1] - y[0]) / VDP_EPS;
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
        j[0] = 0.0;
        j[1] = 1.0;
        j[2] = (-2.0 * y[0] * y[1] - 1.0) / VDP_EPS;
        j[3] = (1.0 - y[0] * y[0]) / VDP_EPS;
        true
    }
}

impl TestProblem for VanDerPol {
    fn name(&self) -> &'static str {
        "vanderpol-1000"
    }
    fn y0(&self) -> Vec<f64> {
        vec![2.0, 0.0]
    }
    fn t_end(&self) -> f64 {
        2.0
    }
    fn reference(&self) -> Vec<f64> {
        vec![1.706167732170483, -0.8928097010247975]
    }
    fn floor(&self) -> Vec<f64> {
        vec![1.0, 1.0]
    }
}

/// HIRES (IVP test set): 8 reactions of light-induced plant growth,
/// `t_end = 321.8122`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hires;

impl FirstOrderProblem for Hires {
    fn dim(&self) -> usize {
        8
    }
    fn rhs(&self, _t: f64, y: &[f64], f: &mut [f64]) {
        f[0] = -1.71 * y[0] + 0.43 * y[1] + 8.32 * y[2] + 0.0007;
        f[1] = 1.71 * y[0] - 8.75 * y[1];
        f[2] = -10.03 * y[2] + 0.43 * y[3] + 0.035 * y[4];
        f[3] = 8.32 * y[1] + 1.71 * y[2] - 1.12 * y[3];
        f[4] = -1.745 * y[4] + 0.43 * y[5] + 0.43 * y[6];
        f[5] = -280.0 * y[5] * y[7] + 0.69 * y[3] + 1.71 * y[4] - 0.43 * y[5] + 0.69 * y[6];
        f[6] = 280.0 * y[5] * y[7] - 1.81 * y[6];
        f[7] = -f[6];
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
        j.fill(0.0);
        let mut set = |r: usize, c: usize, v: f64| j[r * 8 + c] = v;
        set(0, 0, -1.71);
        set(0, 1, 0.43);
        set(0, 2, 8.32);
        set(1, 0, 1.71);
        set(1, 1, -8.75);
        set(2, 2, -10.03);
        set(2, 3, 0.43);
        set(2, 4, 0.035);
        set(3, 1, 8.32);
        set(3, 2, 1.71);
        set(3, 3, -1.12);
        set(4, 4, -1.745);
        set(4, 5, 0.43);
        set(4, 6, 0.43);
        set(5, 3, 0.69);
        set(5, 4, 1.71);
        set(5, 5, -280.0 * y[7] - 0.43);
        set(5, 6, 0.69);
        set(5, 7, -280.0 * y[5]);
        set(6, 5, 280.0 * y[7]);
        set(6, 6, -1.81);
        set(6, 7, 280.0 * y[5]);
        set(7, 5, -280.0 * y[7]);
        set(7, 6, 1.81);
        set(7, 7, -280.0 * y[5]);
        true
    }
}

impl TestProblem for Hires {
    fn name(&self) -> &'static str {
        "hires"
    }
    fn y0(&self) -> Vec<f64> {
        vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0057]
    }
    fn t_end(&self) -> f64 {
        321.8122
    }
    fn reference(&self) -> Vec<f64> {
        vec![
            0.7371312573325668e-3,
            0.1442485726316185e-3,
            0.5888729740967575e-4,
            0.1175651343283149e-2,
            0.2386356198831331e-2,
            0.6238968252742796e-2,
            0.2849998395185769e-2,
            0.2850001604814231e-2,
        ]
    }
    fn floor(&self) -> Vec<f64> {
        vec![1e-4; 8]
    }
}

/// The Oregonator (IVP test set, OREGO): `y(0) = (1, 2, 3)`, `t_end = 360`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Orego;

impl FirstOrderProblem for Orego {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, _t: f64, y: &[f64], f: &mut [f64]) {
        f[0] = 77.27 * (y[1] + y[0] * (1.0 - 8.375e-6 * y[0] - y[1]));
        f[1] = (y[2] - (1.0 + y[0]) * y[1]) / 77.27;
        f[2] = 0.161 * (y[0] - y[2]);
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
        j[0] = 77.27 * (1.0 - 2.0 * 8.375e-6 * y[0] - y[1]);
        j[1] = 77.27 * (1.0 - y[0]);
        j[2] = 0.0;
        j[3] = -y[1] / 77.27;
        j[4] = -(1.0 + y[0]) / 77.27;
        j[5] = 1.0 / 77.27;
        j[6] = 0.161;
        j[7] = 0.0;
        j[8] = -0.161;
        true
    }
}

impl TestProblem for Orego {
    fn name(&self) -> &'static str {
        "orego"
    }
    fn y0(&self) -> Vec<f64> {
        vec![1.0, 2.0, 3.0]
    }
    fn t_end(&self) -> f64 {
        360.0
    }
    fn reference(&self) -> Vec<f64> {
        vec![
            0.1000814870318523e1,
            0.1228178521549917e4,
            0.1320554942846706e3,
        ]
    }
    fn floor(&self) -> Vec<f64> {
        vec![1.0; 3]
    }
}

/// E5 of stiff DETEST (pyrolysis), `y(0) = (1.76e-3, 0, 0, 0)`, `t_end = 1e13`:
/// `y1' = -A y1 - B y1 y3`, `y2' = A y1 - M C y2 y3`,
/// `y3' = A y1 - B y1 y3 - M C y2 y3 + C y4`, `y4' = B y1 y3 - C y4`
/// with `A = 7.89e-10`, `B = 1.1e7`, `C = 1.13e3`, `M = 1e6`.
#[derive(Debug, Clone, Copy, Default)]
pub struct E5;

const E5_A: f64 = 7.89e-10;
const E5_B: f64 = 1.1e7;
const E5_C: f64 = 1.13e3;
const E5_M: f64 = 1e6;
const E5_FLOOR: f64 = 1e-18;

impl FirstOrderProblem for E5 {
    fn dim(&self) -> usize {
        4
    }
    fn rhs(&self, _t: f64, y: &[f64], f: &mut [f64]) {
        let (a, b, c, m) = (E5_A, E5_B, E5_C, E5_M);
        let prod1 = a * y[0];
        let prod2 = b * y[0] * y[2];
        let prod3 = m * c * y[1] * y[2];
        let prod4 = c * y[3];
        f[0] = -prod1 - prod2;
        f[1] = prod1 - prod3;
        f[3] = prod2 - prod4;
        f[2] = f[1] - f[3];
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
        let (a, b, c, m) = (E5_A, E5_B, E5_C, E5_M);
        j.fill(0.0);
        j[0] = -a - b * y[2];
        j[2] = -b * y[0];
        j[4] = a;
        j[5] = -m * c * y[2];
        j[6] = -m * c * y[1];
        j[12] = b * y[2];
        j[14] = b * y[0];
        j[15] = -c;
        // row 2 = row 1 - row 3
        for col in 0..4 {
            j[8 + col] = j[4 + col] - j[12 + col];
        }
        true
    }
}

impl TestProblem for E5 {
    fn name(&self) -> &'static str {
        "e5"
    }
    fn y0(&self) -> Vec<f64> {
        vec![1.76e-3, 0.0, 0.0, 0.0]
    }
    fn t_end(&self) -> f64 {
        1e13
    }
    fn reference(&self) -> Vec<f64> {
        vec![
            0.1152903278711829e-290,
            0.8867655517642120e-22,
            0.8854814626268838e-22,
            0.0,
        ]
    }
    fn floor(&self) -> Vec<f64> {
        vec![E5_FLOOR; 4]
    }
}

/// A chain of `n` unit masses on a line, mass `i` tied to mass `i - 1` (the
/// wall for `i = 0`) by a spring of stiffness `1e4` for even `i` and `1` for
/// odd `i`, with Rayleigh damping `C = 1e-2 K` (stiff modes overdamped,
/// soft modes oscillating). First-order form `y = [x; v]`,
/// `x' = v`, `v' = -K x - C v`, from `x_i = sin(pi (i + 1) / n)`, `v = 0` to
/// `t_end = 10`. The Jacobian is constant, given dense or (when `sparse`)
/// on its sparse pattern.
#[derive(Debug, Clone)]
pub struct SpringChain {
    /// Number of masses (50 in the test set).
    pub n: usize,
    /// Whether to give the Jacobian as a sparse pattern (faer's sparse LU).
    pub sparse: bool,
}

impl SpringChain {
    /// The 50-mass chain of the test set.
    pub fn new(sparse: bool) -> Self {
        Self { n: 50, sparse }
    }

    fn k(&self, i: usize) -> f64 {
        if i.is_multiple_of(2) { 1e4 } else { 1.0 }
    }

    /// `out = K z` for the chain's stiffness matrix `K`, `z_i = z(i)`.
    fn stiffness_times(&self, z: impl Fn(usize) -> f64, out: &mut [f64]) {
        let n = self.n;
        for i in 0..n {
            let left = if i == 0 { 0.0 } else { z(i - 1) };
            let mut s = self.k(i) * (z(i) - left);
            if i + 1 < n {
                s -= self.k(i + 1) * (z(i + 1) - z(i));
            }
            out[i] = s;
        }
    }

    /// The entries `(row, col, value)` of the Jacobian `[[0, I], [-K, -0.01 K]]`.
    fn entries(&self) -> Vec<(usize, usize, f64)> {
        let n = self.n;
        let mut e = Vec::new();
        for i in 0..n {
            e.push((i, i, 0.0));
            e.push((i, n + i, 1.0));
        }
        for i in 0..n {
            let diag = self.k(i) + if i + 1 < n { self.k(i + 1) } else { 0.0 };
            for (c, kv) in [
                (i.wrapping_sub(1), -self.k(i)),
                (i, diag),
                (i + 1, -self.k(i + 1)),
            ] {
                if c < n {
                    e.push((n + i, c, -kv));
                    e.push((n + i, n + c, -0.01 * kv));
                }
            }
        }
        e
    }

    /// The exact solution `exp(t A) y0` of the linear system `y' = A y`, by
    /// scaling and squaring with a Taylor polynomial (`||A t / 2^s|| <= 1/2`,
    /// 20 terms: truncation below `1e-22` relative).
    pub fn exact(&self, t: f64) -> Vec<f64> {
        let m = 2 * self.n;
        let mut a = vec![0.0; m * m];
        for (r, c, v) in self.entries() {
            a[r * m + c] += v * t;
        }
        let norm = (0..m)
            .map(|r| a[r * m..(r + 1) * m].iter().map(|v| v.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        let s = (norm / 0.5).log2().ceil().max(0.0) as i32;
        let scale = 0.5f64.powi(s);
        a.iter_mut().for_each(|v| *v *= scale);
        let matmul = |x: &[f64], y: &[f64]| {
            let mut z = vec![0.0; m * m];
            for i in 0..m {
                for k in 0..m {
                    let xik = x[i * m + k];
                    if xik != 0.0 {
                        for j in 0..m {
                            z[i * m + j] += xik * y[k * m + j];
                        }
                    }
                }
            }
            z
        };
        let mut e = vec![0.0; m * m];
        let mut term = vec![0.0; m * m];
        for i in 0..m {
            e[i * m + i] = 1.0;
            term[i * m + i] = 1.0;
        }
        for k in 1..=20 {
            term = matmul(&term, &a);
            term.iter_mut().for_each(|v| *v /= k as f64);
            e.iter_mut().zip(&term).for_each(|(x, y)| *x += y);
        }
        for _ in 0..s {
            e = matmul(&e, &e);
        }
        let y0 = self.y0();
        (0..m)
            .map(|r| (0..m).map(|c| e[r * m + c] * y0[c]).sum())
            .collect()
    }
}

impl FirstOrderProblem for SpringChain {
    fn dim(&self) -> usize {
        2 * self.n
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let n = self.n;
        let (x, v) = y.split_at(n);
        let (dx, dv) = dy.split_at_mut(n);
        dx.copy_from_slice(v);
        // v' = -K x - 0.01 K v = -K (x + 0.01 v).
        self.stiffness_times(|i| x[i] + 0.01 * v[i], dv);
        dv.iter_mut().for_each(|a| *a = -*a);
    }
    fn jacobian(&self, _t: f64, _y: &[f64], j: &mut [f64]) -> bool {
        let m = 2 * self.n;
        j.fill(0.0);
        for (r, c, v) in self.entries() {
            j[r * m + c] += v;
        }
        true
    }
    fn sparse_jacobian_pattern(&self) -> Option<sprs::CsMat<f64>> {
        if !self.sparse {
            return None;
        }
        let m = 2 * self.n;
        let mut tri = sprs::TriMat::new((m, m));
        for (r, c, _) in self.entries() {
            tri.add_triplet(r, c, 0.0);
        }
        for i in self.n..m {
            tri.add_triplet(i, i, 0.0);
        }
        Some(tri.to_csr())
    }
    fn jacobian_sparse(&self, _t: f64, _y: &[f64], jac: &mut sprs::CsMat<f64>) -> bool {
        jac.data_mut().fill(0.0);
        for (r, c, v) in self.entries() {
            if let Some(x) = jac.get_mut(r, c) {
                *x += v;
            }
        }
        true
    }
}

impl TestProblem for SpringChain {
    fn name(&self) -> &'static str {
        if self.sparse {
            "spring-chain-50-sparse"
        } else {
            "spring-chain-50"
        }
    }
    fn y0(&self) -> Vec<f64> {
        let n = self.n;
        let mut y = vec![0.0; 2 * n];
        for i in 0..n {
            y[i] = (std::f64::consts::PI * (i + 1) as f64 / n as f64).sin();
        }
        y
    }
    fn t_end(&self) -> f64 {
        10.0
    }
    fn reference(&self) -> Vec<f64> {
        self.exact(self.t_end())
    }
    fn floor(&self) -> Vec<f64> {
        vec![1e-3; 2 * self.n]
    }
}
