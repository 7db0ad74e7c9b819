//! [`DenseLu`]: faer's dense LU with partial pivoting, factored in place
//! into storage kept between setups, so that neither a refactorisation nor
//! a solve allocates.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
use hookean_sparse::SparseError;

use super::{LinearSolveStats, LinearSolver};
use crate::error::{NonlinearError, check_len};

/// Dense LU with partial pivoting (faer's `lu_in_place`), for small general
/// Jacobians (`faer::Mat<f64>`): the tutorial's scalar examples, first-order
/// systems with up to a few hundred unknowns.
///
/// The factors, the permutation and faer's workspace are kept and reused
/// while the dimension stays: a [`setup`](LinearSolver::setup) after the
/// first and every [`solve`](LinearSolver::solve) allocate nothing. A solve
/// is the permutation, then forward and back substitution by columns on the
/// factors `P A = L U` (unit `L` below the diagonal, `U` on and above it):
/// the operations of faer's `solve_in_place` without its dispatch, which
/// cost about 900 instructions per solve of a 2 x 2 system (callgrind,
/// docs/PERFORMANCE.md).
///
/// A pivot `|u_kk| <= n eps max |u_ij|` is reported as
/// [`NonlinearError::SingularJacobian`].
pub struct DenseLu {
    /// `A`, overwritten by its factors, column-major `n x n`.
    lu: Vec<f64>,
    /// The forward row permutation, `(P b)_i = b[perm[i]]`, and its inverse.
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    mem: MemBuffer,
    n: usize,
    ready: bool,
}

impl std::fmt::Debug for DenseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseLu")
            .field("n", &self.n)
            .field("ready", &self.ready)
            .field("perm", &self.perm)
            .finish_non_exhaustive()
    }
}

impl Default for DenseLu {
    fn default() -> Self {
        Self::new()
    }
}

impl DenseLu {
    /// An empty solver.
    pub fn new() -> Self {
        Self {
            lu: Vec::new(),
            perm: Vec::new(),
            perm_inv: Vec::new(),
            mem: MemBuffer::new(faer::dyn_stack::StackReq::EMPTY),
            n: 0,
            ready: false,
        }
    }

    /// Storage for dimension `n` (allocates only when `n` changes).
    fn reserve(&mut self, n: usize) {
        if self.lu.len() == n * n && self.perm.len() == n {
            return;
        }
        self.lu = vec![0.0; n * n];
        self.perm = vec![0; n];
        self.perm_inv = vec![0; n];
        let req = lu_in_place_scratch::<usize, f64>(n, n, faer::Par::Seq, Default::default());
        self.mem = MemBuffer::new(req);
    }
}

impl LinearSolver<faer::Mat<f64>> for DenseLu {
    fn setup(&mut self, jac: &faer::Mat<f64>) -> Result<(), NonlinearError> {
        self.ready = false;
        let (r, c) = (jac.nrows(), jac.ncols());
        if r != c {
            return Err(SparseError::NotSquare { rows: r, cols: c }.into());
        }
        self.reserve(r);
        for j in 0..c {
            let (src, dst) = (jac.col_as_slice(j), &mut self.lu[j * r..(j + 1) * r]);
            if let Some(i) = src.iter().position(|v| !v.is_finite()) {
                return Err(SparseError::NonFinite {
                    what: "Jacobian",
                    index: Some(j * r + i),
                }
                .into());
            }
            dst.copy_from_slice(src);
        }
        if r <= SMALL_FACTOR {
            factor_small(&mut self.lu, &mut self.perm, &mut self.perm_inv);
        } else {
            lu_in_place(
                faer::MatMut::from_column_major_slice_mut(&mut self.lu, r, c),
                &mut self.perm,
                &mut self.perm_inv,
                faer::Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            );
        }
        let mut umax = 0.0f64;
        for j in 0..c {
            for &u in &self.lu[j * r..j * r + j + 1] {
                umax = umax.max(u.abs());
            }
        }
        let tiny = r as f64 * f64::EPSILON * umax;
        for k in 0..r {
            let p = self.lu[k * r + k];
            if !(p.abs() > tiny) {
                return Err(NonlinearError::SingularJacobian { pivot: k, value: p });
            }
        }
        self.n = r;
        self.ready = true;
        Ok(())
    }

    fn solve(
        &mut self,
        _jac: &faer::Mat<f64>,
        rhs: &[f64],
        x: &mut [f64],
        _rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        if !self.ready {
            return Err(NonlinearError::NotReady(
                "DenseLu::solve before a successful setup",
            ));
        }
        check_len("right-hand side", rhs, self.n)?;
        check_len("solution", x, self.n)?;
        let n = self.n;
        if n <= SMALL {
            substitute_small(&self.lu[..n * n], &self.perm[..n], &rhs[..n], &mut x[..n]);
            return Ok(LinearSolveStats {
                converged: true,
                ..Default::default()
            });
        }
        for (xi, &p) in x.iter_mut().zip(&self.perm) {
            *xi = rhs[p];
        }
        // L y = P b by columns (unit diagonal), then U x = y by columns.
        for (j, col) in self.lu.chunks_exact(n).enumerate() {
            let (head, tail) = x.split_at_mut(j + 1);
            let xj = head[j];
            if xj != 0.0 {
                for (xi, lij) in tail.iter_mut().zip(&col[j + 1..]) {
                    *xi -= lij * xj;
                }
            }
        }
        for (j, col) in self.lu.chunks_exact(n).enumerate().rev() {
            let (head, tail) = x.split_at_mut(j);
            let xj = tail[0] / col[j];
            tail[0] = xj;
            if xj != 0.0 {
                for (xi, uij) in head.iter_mut().zip(&col[..j]) {
                    *xi -= uij * xj;
                }
            }
        }
        Ok(LinearSolveStats {
            converged: true,
            ..Default::default()
        })
    }

    fn is_direct(&self) -> bool {
        true
    }
}

/// Up to this dimension a solve runs [`substitute_small`] with the
/// dimension as a constant (loops unrolled, no bounds checks left): the
/// iterator chains of the general path (split slices, zipped columns) cost
/// more than the arithmetic on systems of a few unknowns.
const SMALL: usize = 8;

/// Up to this dimension [`DenseLu::setup`] factors by [`factor_small`]:
/// above it the fused updates, calls to `fma` on a baseline x86-64 build,
/// cost more than faer's dispatch saves (HIRES, 8 unknowns: 1.95 M -> 2.02 M
/// instructions per run, callgrind).
const SMALL_FACTOR: usize = 4;

/// `P A = L U` in place (column-major `a`, `n = perm.len() <= SMALL`) by
/// the right-looking partial-pivoting elimination of faer's unblocked
/// kernel, which faer's `lu_in_place` runs below 16 columns: per column the
/// first largest `|a_ik|` is the pivot, whole rows are swapped, the column
/// below is scaled by the pivot's reciprocal, then the rank-1 update with
/// fused multiply-adds, as faer's kernels do it where the processor has
/// them (x86-64 with FMA, aarch64). The same operations in the same order,
/// so the same bits there (checked against faer in the tests), without
/// faer's dispatch: about 875 instructions of
/// faer's per 2 x 2 factorisation (callgrind, docs/PERFORMANCE.md).
#[allow(clippy::needless_range_loop)]
fn factor_small(a: &mut [f64], perm: &mut [usize], perm_inv: &mut [usize]) {
    let n = perm.len();
    let a = &mut a[..n * n];
    for (i, p) in perm.iter_mut().enumerate() {
        *p = i;
    }
    for k in 0..n {
        let mut imax = k;
        let mut max = 0.0;
        for i in k..n {
            let v = a[k * n + i].abs();
            if v > max {
                max = v;
                imax = i;
            }
        }
        if imax != k {
            for j in 0..n {
                a.swap(j * n + k, j * n + imax);
            }
            perm.swap(k, imax);
        }
        let inv = 1.0 / a[k * n + k];
        for i in k + 1..n {
            a[k * n + i] *= inv;
        }
        for j in k + 1..n {
            let ukj = a[j * n + k];
            for i in k + 1..n {
                // faer's kernels fuse the update (one rounding).
                a[j * n + i] = (-a[k * n + i]).mul_add(ukj, a[j * n + i]);
            }
        }
    }
    for (i, &p) in perm.iter().enumerate() {
        perm_inv[p] = i;
    }
}

/// `x = A^{-1} b` from the factors `P A = L U` of [`DenseLu::solve`] for
/// `n = x.len() <= SMALL`, dispatched to [`substitute_n`].
fn substitute_small(lu: &[f64], perm: &[usize], b: &[f64], x: &mut [f64]) {
    match x.len() {
        1 => substitute_n::<1>(lu, perm, b, x),
        2 => substitute_n::<2>(lu, perm, b, x),
        3 => substitute_n::<3>(lu, perm, b, x),
        4 => substitute_n::<4>(lu, perm, b, x),
        5 => substitute_n::<5>(lu, perm, b, x),
        6 => substitute_n::<6>(lu, perm, b, x),
        7 => substitute_n::<7>(lu, perm, b, x),
        _ => substitute_n::<8>(lu, perm, b, x),
    }
}

/// The permutation, then forward and back substitution by columns on
/// column-major factors of dimension `N`: the same operations in the same
/// order as the general path of [`DenseLu::solve`], so the same bits.
#[inline]
#[allow(clippy::needless_range_loop)]
fn substitute_n<const N: usize>(lu: &[f64], perm: &[usize], b: &[f64], x: &mut [f64]) {
    let (lu, perm, x) = (&lu[..N * N], &perm[..N], &mut x[..N]);
    for i in 0..N {
        x[i] = b[perm[i]];
    }
    for j in 0..N {
        let xj = x[j];
        if xj != 0.0 {
            for i in j + 1..N {
                x[i] -= lu[j * N + i] * xj;
            }
        }
    }
    for j in (0..N).rev() {
        let xj = x[j] / lu[j * N + j];
        x[j] = xj;
        if xj != 0.0 {
            for i in 0..j {
                x[i] -= lu[j * N + i] * xj;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pseudo-random matrices (a fixed LCG), some with exact zeros, ties
    /// and scaled rows so that the pivoting has choices to make.
    fn matrices(n: usize) -> Vec<Vec<f64>> {
        let mut state = 0x2545_f491_4f6c_dd1du64 ^ n as u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        (0..40)
            .map(|case| {
                (0..n * n)
                    .map(|idx| {
                        let v = next();
                        match case % 4 {
                            1 if idx % 3 == 0 => 0.0,
                            2 => (v * 4.0).round() / 4.0,
                            3 => v * 10f64.powi((idx % n) as i32 * 3 - 6),
                            _ => v,
                        }
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_small_factorisation_and_solve_are_faers_bit_for_bit() {
        for n in 1..=SMALL {
            for a in matrices(n) {
                let mut ours = a.clone();
                let (mut perm, mut perm_inv) = (vec![0; n], vec![0; n]);
                factor_small(&mut ours, &mut perm, &mut perm_inv);
                let mut theirs = a.clone();
                let (mut fperm, mut fperm_inv) = (vec![0; n], vec![0; n]);
                let req =
                    lu_in_place_scratch::<usize, f64>(n, n, faer::Par::Seq, Default::default());
                let mut mem = MemBuffer::new(req);
                lu_in_place(
                    faer::MatMut::from_column_major_slice_mut(&mut theirs, n, n),
                    &mut fperm,
                    &mut fperm_inv,
                    faer::Par::Seq,
                    MemStack::new(&mut mem),
                    Default::default(),
                );
                assert_eq!(perm, fperm, "n = {n}");
                assert_eq!(perm_inv, fperm_inv, "n = {n}");
                // Bits, NaN's sign and payload aside (a zero pivot: setup
                // rejects such factors).
                let bits = |v: &[f64]| {
                    v.iter()
                        .map(|x| if x.is_nan() { u64::MAX } else { x.to_bits() })
                        .collect::<Vec<_>>()
                };
                assert_eq!(bits(&ours), bits(&theirs), "n = {n}");
                // The solve: A x = b for x = (1, 2, ..., n), against the
                // residual (an independent check of the substitution).
                let m = faer::Mat::from_fn(n, n, |i, j| a[j * n + i]);
                if (0..n).any(|k| ours[k * n + k].abs() < 1e-3) {
                    continue;
                }
                let x_true: Vec<f64> = (1..=n).map(|v| v as f64).collect();
                let b: Vec<f64> = (0..n)
                    .map(|i| (0..n).map(|j| m[(i, j)] * x_true[j]).sum())
                    .collect();
                let mut lu = DenseLu::new();
                lu.setup(&m).unwrap();
                let mut x = vec![0.0; n];
                lu.solve(&m, &b, &mut x, 0.0).unwrap();
                let r: f64 = (0..n)
                    .map(|i| ((0..n).map(|j| m[(i, j)] * x[j]).sum::<f64>() - b[i]).abs())
                    .fold(0.0, f64::max);
                let scale: f64 = b.iter().map(|v| v.abs()).fold(1.0, f64::max);
                assert!(r <= 1e-10 * scale, "n = {n}: residual {r}");
            }
        }
    }

    #[test]
    fn dense_lu_solves_and_detects_singularity() {
        let a = faer::mat![[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]];
        let mut lu = DenseLu::new();
        lu.setup(&a).unwrap();
        let mut x = [0.0; 3];
        lu.solve(&a, &[3.0, 2.0, 4.0], &mut x, 0.0).unwrap();
        // Solution (1, 1, 1) by inspection.
        for v in x {
            approx::assert_abs_diff_eq!(v, 1.0, epsilon = 1e-14);
        }
        let s = faer::mat![[1.0, 2.0], [2.0, 4.0]];
        assert!(matches!(
            lu.setup(&s),
            Err(NonlinearError::SingularJacobian { pivot: 1, .. })
        ));
        assert!(lu.solve(&s, &[1.0, 1.0], &mut [0.0; 2], 0.0).is_err());
        let nan = faer::mat![[f64::NAN]];
        assert!(lu.setup(&nan).is_err());
        assert!(lu.setup(&faer::Mat::<f64>::zeros(2, 3)).is_err());
    }

    #[test]
    fn dense_lu_pivots_and_matches_an_independent_solve() {
        // A 5 x 5 matrix whose first column needs a row exchange; the
        // solution is checked against Gaussian elimination of the testkit.
        let rows = [
            [0.0, 2.0, -1.0, 0.5, 3.0],
            [4.0, -1.0, 0.0, 2.0, 1.0],
            [-2.0, 3.0, 1.0, 0.0, -4.0],
            [1.0, 0.0, 5.0, -3.0, 2.0],
            [0.5, -2.0, 1.5, 1.0, 0.0],
        ];
        let a = faer::Mat::from_fn(5, 5, |i, j| rows[i][j]);
        let b = [1.0, -2.0, 0.5, 3.0, -1.5];
        let mut lu = DenseLu::new();
        lu.setup(&a).unwrap();
        assert!(lu.perm.iter().enumerate().any(|(i, &p)| i != p), "pivoting");
        let mut x = [0.0; 5];
        lu.solve(&a, &b, &mut x, 0.0).unwrap();
        let dense: Vec<Vec<f64>> = rows.iter().map(|r| r.to_vec()).collect();
        let exact = hookean_testkit::dense::solve(&dense, &b);
        for i in 0..5 {
            approx::assert_abs_diff_eq!(x[i], exact[i], epsilon = 1e-13);
        }
        // A refill of the same size reuses the storage: the factors follow.
        let a2 = faer::Mat::from_fn(5, 5, |i, j| 2.0 * rows[i][j]);
        lu.setup(&a2).unwrap();
        lu.solve(&a2, &b, &mut x, 0.0).unwrap();
        for i in 0..5 {
            approx::assert_abs_diff_eq!(x[i], exact[i] / 2.0, epsilon = 1e-13);
        }
    }
}
