//! Incomplete Cholesky with zero fill-in, IC(0) (the tutorial's "ICC"),
//! and its modified form MIC(0) on block matrices.

use super::block_ic0::BlockFactor;
use super::{Preconditioner, PreconditionerSetup, as_csr, square_dim};
use crate::error::SparseError;
use crate::matrix::SymBlockMatrix;

const NONE: usize = usize::MAX;

/// IC(0): `A ~ L L^T` with `L` restricted to the lower triangle of `A`'s own
/// pattern ("formally factorising A and dropping all intermediate values not
/// fitting the sparsity pattern", section 4.1).
///
/// The factorisation runs on the unit-diagonal scaling `S A S`,
/// `S = diag(a_ii)^-1/2`. When a pivot is not positive it is retried on
/// `S A S + shift I`, with `shift` starting at `initial_shift` (1e-3) and
/// doubling, as Eigen's `IncompleteCholesky` does; [`shift`](Self::shift)
/// reports the value that succeeded (0 when none was needed).
///
/// The symbolic part (the pattern of `L` and where each entry comes from)
/// is computed once per sparsity pattern; refills only redo the numbers.
///
/// For a [`SymBlockMatrix`] the factorisation runs on 3x3 blocks,
/// `A ~ (D + W)^T D^-1 (D + W)` with `W` on the matrix's own block layout:
/// the same preconditioner (the pattern's blocks are dense, so scalar IC(0)
/// keeps exactly the fill between particles whose block is stored), with
/// one application costing about one symmetric SpMV. From 2 048 block
/// rows, a banded pattern (a cloth grid in its natural order) is factored
/// in the order `A, B reversed, S` (two domains and the separator between
/// them, one level of nested dissection): IC(0) of `P A P^T`, whose two
/// triangular solves run over `A` and `B` on two threads. It needs as many
/// PCG iterations as the natural order (64 on the 64² cloth of the peers'
/// gallery) and gives the same bits on any number of threads.
///
/// [`modified`](Self::modified) gives MIC(0) (Gustafsson 1978): the fill
/// IC(0) drops is subtracted, times a relaxation `omega`, from the diagonal
/// blocks it would have coupled, so that the preconditioner keeps the row
/// sums of `A`. On the implicit cloth systems it needs a half to three
/// quarters of the iterations of IC(0) (docs/PERFORMANCE.md). It is implemented for
/// [`SymBlockMatrix`] only (the right-looking block factorisation); setting
/// it up from a scalar `sprs` matrix is an error.
///
/// ```
/// use std::sync::Arc;
/// use hookean_sparse::{BlockPattern, IncompleteCholesky, Preconditioner, PreconditionerSetup, SymBlockMatrix};
/// // Three particles in a triangle: the fill between the last two is kept,
/// // so MIC(0) and IC(0) coincide here and M = A exactly.
/// let pattern = Arc::new(BlockPattern::new(3, [(0, 1), (0, 2), (1, 2)])?);
/// let mut a = SymBlockMatrix::new(pattern);
/// for (i, j) in [(0, 1), (0, 2), (1, 2)] {
///     a.add_to_block(i, j, &[[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])?;
/// }
/// a.add_to_diagonal(&[3.0; 9])?;
/// let mut mic = IncompleteCholesky::modified(0.99)?;
/// mic.setup(&a)?;
/// let b = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mut z = [0.0; 9];
/// mic.apply(&b, &mut z);
/// let mut az = [0.0; 9];
/// a.mul_vec(&z, &mut az)?;
/// assert!(az.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12));
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Clone)]
pub struct IncompleteCholesky {
    initial_shift: f64,
    /// MIC(0) relaxation (0: IC(0)).
    omega: f64,
    shift: f64,
    source: Source,
    l_ptr: Vec<usize>,
    l_col: Vec<usize>,
    /// For every entry of `L`, the index of the matching value of `A` in its
    /// flat value array, or `NONE` for a diagonal that `A` does not store.
    map: Vec<usize>,
    l_val: Vec<f64>,
    inv_diag: Vec<f64>,
    scale: Vec<f64>,
    marker: Vec<usize>,
}

#[derive(Debug, Clone)]
enum Source {
    None,
    Block(Box<BlockFactor>),
    Csr {
        indptr: Vec<usize>,
        indices: Vec<usize>,
    },
}

impl Default for IncompleteCholesky {
    fn default() -> Self {
        Self::new()
    }
}

impl IncompleteCholesky {
    /// An empty IC(0) preconditioner with Eigen's initial shift `1e-3`.
    pub fn new() -> Self {
        Self {
            initial_shift: 1e-3,
            omega: 0.0,
            shift: 0.0,
            source: Source::None,
            l_ptr: Vec::new(),
            l_col: Vec::new(),
            map: Vec::new(),
            l_val: Vec::new(),
            inv_diag: Vec::new(),
            scale: Vec::new(),
            marker: Vec::new(),
        }
    }

    /// An empty MIC(0) preconditioner: the dropped fill is compensated on
    /// the diagonal with weight `omega` in `[0, 1]` (0 is IC(0), 1 keeps the
    /// row sums exactly; slightly below 1 is the usual choice).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if `omega` is not in `[0, 1]`.
    pub fn modified(omega: f64) -> Result<Self, SparseError> {
        if !(0.0..=1.0).contains(&omega) {
            return Err(SparseError::InvalidParameter {
                name: "omega",
                message: format!("the MIC(0) relaxation must lie in [0, 1], got {omega:?}"),
            });
        }
        Ok(Self {
            omega,
            ..Self::new()
        })
    }

    /// The MIC(0) relaxation `omega` (0 for IC(0)).
    pub fn relaxation(&self) -> f64 {
        self.omega
    }

    /// The diagonal shift (relative to the unit-diagonal scaled matrix) that
    /// the last successful [`setup`](PreconditionerSetup::setup) used.
    pub fn shift(&self) -> f64 {
        self.shift
    }

    /// Number of stored entries of `L` (diagonal included).
    pub fn nnz(&self) -> usize {
        match &self.source {
            Source::Block(f) => f.nnz(),
            _ => self.l_col.len(),
        }
    }

    fn n(&self) -> usize {
        match &self.source {
            Source::Block(f) => 3 * f.n_blocks(),
            _ => self.l_ptr.len().saturating_sub(1),
        }
    }

    fn symbolic_csr(&mut self, n: usize, indptr: &[usize], indices: &[usize]) {
        self.l_ptr.clear();
        self.l_col.clear();
        self.map.clear();
        self.l_ptr.push(0);
        for i in 0..n {
            let mut diag = NONE;
            for k in indptr[i]..indptr[i + 1] {
                let j = indices[k];
                if j < i {
                    self.l_col.push(j);
                    self.map.push(k);
                } else if j == i {
                    diag = k;
                }
            }
            self.l_col.push(i);
            self.map.push(diag);
            self.l_ptr.push(self.l_col.len());
        }
        self.source = Source::Csr {
            indptr: indptr.to_vec(),
            indices: indices.to_vec(),
        };
    }

    /// The numeric factorisation (scalar CSR input) with diagonal scaling
    /// and the shift loop.
    fn numeric(&mut self, values: &[f64]) -> Result<(), SparseError> {
        let n = self.n();
        check_finite(values).inspect_err(|_| self.source = Source::None)?;
        self.l_val.resize(self.l_col.len(), 0.0);
        self.inv_diag.resize(n, 0.0);
        self.scale.resize(n, 0.0);
        self.marker.clear();
        self.marker.resize(n, NONE);
        let mut min_diag = f64::INFINITY;
        for i in 0..n {
            let p = self.map[self.l_ptr[i + 1] - 1];
            let d = if p == NONE { 0.0 } else { values[p] };
            self.scale[i] = if d > 0.0 { 1.0 / d.sqrt() } else { 1.0 };
            min_diag = min_diag.min(if d > 0.0 { 1.0 } else { d });
        }
        self.shift_loop(min_diag, |this, shift| this.try_factor(values, shift))
    }

    /// Factors with `shift = 0` (or the shift that makes a non-positive
    /// scaled diagonal `min_diag` positive), doubling the shift from
    /// `initial_shift` after every failed attempt, as Eigen does.
    fn shift_loop(
        &mut self,
        min_diag: f64,
        mut attempt: impl FnMut(&mut Self, f64) -> Result<(), usize>,
    ) -> Result<(), SparseError> {
        let mut shift = if min_diag <= 0.0 {
            self.initial_shift - min_diag
        } else {
            0.0
        };
        let mut failed_row = 0;
        for _attempt in 0..64 {
            match attempt(self, shift) {
                Ok(()) => {
                    self.shift = shift;
                    return Ok(());
                }
                Err(row) => {
                    failed_row = row;
                    shift = (2.0 * shift).max(self.initial_shift);
                }
            }
        }
        Err(SparseError::IncompleteCholeskyFailed {
            row: failed_row,
            shift,
        })
    }

    /// Row-by-row IC(0) of `S A S + shift I`; `Err(row)` at a non-positive pivot.
    fn try_factor(&mut self, values: &[f64], shift: f64) -> Result<(), usize> {
        let n = self.n();
        for i in 0..n {
            let (start, end) = (self.l_ptr[i], self.l_ptr[i + 1]);
            let pd = end - 1;
            for p in start..end {
                let j = self.l_col[p];
                let src = self.map[p];
                let a = if src == NONE { 0.0 } else { values[src] };
                self.l_val[p] = self.scale[i] * a * self.scale[j];
                self.marker[j] = p;
            }
            self.l_val[pd] += shift;
            for p in start..pd {
                let k = self.l_col[p];
                // l_ik = (a_ik - sum_{j < k} l_ij l_kj) / l_kk over the common pattern.
                let mut acc = self.l_val[p];
                for q in self.l_ptr[k]..self.l_ptr[k + 1] - 1 {
                    let m = self.marker[self.l_col[q]];
                    if m != NONE && m < p {
                        acc -= self.l_val[m] * self.l_val[q];
                    }
                }
                self.l_val[p] = acc * self.inv_diag[k];
            }
            let mut d = self.l_val[pd];
            for p in start..pd {
                d -= self.l_val[p] * self.l_val[p];
            }
            for p in start..end {
                self.marker[self.l_col[p]] = NONE;
            }
            if !(d > 0.0 && d.is_finite()) {
                return Err(i);
            }
            let l = d.sqrt();
            self.l_val[pd] = l;
            self.inv_diag[i] = 1.0 / l;
        }
        Ok(())
    }
}

impl Preconditioner for IncompleteCholesky {
    fn dim(&self) -> Option<usize> {
        Some(if matches!(self.source, Source::None) {
            0
        } else {
            self.n()
        })
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) {
        assert!(
            !matches!(self.source, Source::None),
            "incomplete Cholesky used before a successful setup"
        );
        if let Source::Block(f) = &self.source {
            f.apply(r, z);
            return;
        }
        let n = self.n();
        let (l_ptr, l_col, l_val) = (&self.l_ptr, &self.l_col, &self.l_val);
        // Forward: L y = S r.
        for i in 0..n {
            let mut acc = self.scale[i] * r[i];
            for p in l_ptr[i]..l_ptr[i + 1] - 1 {
                acc -= l_val[p] * z[l_col[p]];
            }
            z[i] = acc * self.inv_diag[i];
        }
        // Backward: L^T x = y, pushing each finished x_i into earlier rows.
        for i in (0..n).rev() {
            let xi = z[i] * self.inv_diag[i];
            z[i] = xi;
            for p in l_ptr[i]..l_ptr[i + 1] - 1 {
                z[l_col[p]] -= l_val[p] * xi;
            }
        }
        for (zi, s) in z.iter_mut().zip(&self.scale) {
            *zi *= s;
        }
    }

    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        match &self.source {
            Source::Block(f) => f.update_and_apply(alpha, q, r, z),
            _ => {
                let mut rr = 0.0;
                for (ri, qi) in r.iter_mut().zip(q) {
                    *ri -= alpha * qi;
                    rr += *ri * *ri;
                }
                (rr, self.apply_dot(r, z))
            }
        }
    }
}

fn check_finite(values: &[f64]) -> Result<(), SparseError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(SparseError::NonFinite {
            what: "matrix",
            index: Some(k),
        }),
        None => Ok(()),
    }
}

impl PreconditionerSetup<SymBlockMatrix> for IncompleteCholesky {
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        let source = std::mem::replace(&mut self.source, Source::None);
        let mut factor = match source {
            Source::Block(f) if f.is_for(a.pattern()) => f,
            _ => Box::new(BlockFactor::new(a.pattern())),
        };
        let min_diag = (0..a.n_blocks())
            .flat_map(|i| {
                let d = a.diagonal_block(i);
                [d[0][0], d[1][1], d[2][2]]
            })
            .fold(f64::INFINITY, |m, d| m.min(if d > 0.0 { 1.0 } else { d }));
        // A non-finite entry always ends in a failed pivot (it reaches a
        // diagonal block), so the matrix is only scanned after a failure.
        let values = a.values().as_flattened().as_flattened();
        let omega = self.omega;
        let mut loaded = factor.load(a);
        let (mut checked, mut non_finite) = (false, None);
        let result = self.shift_loop(min_diag, |_, shift| {
            if non_finite.is_some() {
                return Err(0);
            }
            let r = loaded.factor(shift, omega);
            if r.is_err() && !checked {
                checked = true;
                non_finite = check_finite(values).err();
            }
            r
        });
        if let Some(e) = non_finite {
            return Err(e);
        }
        if result.is_ok() {
            self.source = Source::Block(factor);
        }
        result
    }
}

impl PreconditionerSetup<sprs::CsMat<f64>> for IncompleteCholesky {
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        if self.omega != 0.0 {
            return Err(SparseError::InvalidParameter {
                name: "preconditioner",
                message: "MIC(0) is implemented for 3x3 block matrices (SymBlockMatrix) only"
                    .into(),
            });
        }
        let n = square_dim(a)?;
        let a = &*as_csr(a);
        let indptr = a.proper_indptr();
        let same = matches!(&self.source,
            Source::Csr { indptr: p, indices: i } if p.as_slice() == &*indptr && i.as_slice() == a.indices());
        if !same {
            super::check_both_triangles(&indptr, a.indices(), "IC(0)")?;
            self.symbolic_csr(n, &indptr, a.indices());
        }
        self.numeric(a.data())
    }
}

#[cfg(test)]
mod tests {
    use super::super::testutil::*;
    use super::*;

    fn tridiagonal(n: usize) -> sprs::CsMat<f64> {
        let mut t = sprs::TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 2.5 + (i % 3) as f64);
            if i + 1 < n {
                t.add_triplet(i, i + 1, -1.0 - 0.1 * i as f64);
                t.add_triplet(i + 1, i, -1.0 - 0.1 * i as f64);
            }
        }
        t.to_csr()
    }

    fn to_dense(a: &sprs::CsMat<f64>) -> Vec<Vec<f64>> {
        let n = a.rows();
        let mut d = vec![vec![0.0; n]; n];
        for (&v, (r, c)) in a.iter() {
            d[r][c] = v;
        }
        d
    }

    #[test]
    fn ic0_of_a_tridiagonal_matrix_is_the_exact_cholesky_factor() {
        // No fill-in occurs, so IC(0) = Cholesky and M^-1 = A^-1.
        let a = tridiagonal(12);
        let mut p = IncompleteCholesky::new();
        p.setup(&a).unwrap();
        assert_eq!(p.shift(), 0.0);
        let r = rhs(12);
        let mut z = vec![0.0; 12];
        p.apply(&r, &mut z);
        let exact = dense_solve(&to_dense(&a), &r);
        assert!(rel_diff(&z, &exact) < 1e-13);
        // And the factor itself: L L^T of the scaled matrix reproduces S A S.
        let d = to_dense(&a);
        for i in 0..12 {
            let li: Vec<f64> = (0..12).map(|j| entry(&p, i, j)).collect();
            for j in 0..12 {
                let lj: Vec<f64> = (0..12).map(|k| entry(&p, j, k)).collect();
                let llt: f64 = li.iter().zip(&lj).map(|(x, y)| x * y).sum();
                let sas = p.scale[i] * d[i][j] * p.scale[j];
                assert!((llt - sas).abs() < 1e-14, "({i},{j})");
            }
        }
    }

    fn entry(p: &IncompleteCholesky, i: usize, j: usize) -> f64 {
        (p.l_ptr[i]..p.l_ptr[i + 1])
            .find(|&q| p.l_col[q] == j)
            .map_or(0.0, |q| p.l_val[q])
    }

    #[test]
    fn block_and_csr_setups_give_the_same_preconditioner() {
        let a = spd_block_matrix(3, 3);
        let r = rhs(a.dim());
        let mut pb = IncompleteCholesky::new();
        pb.setup(&a).unwrap();
        let mut pc = IncompleteCholesky::new();
        pc.setup(&a.to_csr()).unwrap();
        let (mut zb, mut zc) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        pb.apply(&r, &mut zb);
        pc.apply(&r, &mut zc);
        assert!(rel_diff(&zb, &zc) < 1e-13);
        assert_eq!(pb.nnz(), pc.nnz());
    }

    #[test]
    fn ic0_keeps_the_pattern_of_a_and_matches_a_on_it() {
        // On the pattern of A, (L L^T)_ij = (S A S)_ij: the defining property of IC(0).
        let a = spd_block_matrix(3, 2);
        let csr = a.to_csr();
        let mut p = IncompleteCholesky::new();
        p.setup(&csr).unwrap();
        assert_eq!(p.shift(), 0.0);
        let n = csr.rows();
        for (&v, (i, j)) in csr.iter() {
            if j > i {
                continue;
            }
            let llt: f64 = (0..=j).map(|k| entry(&p, i, k) * entry(&p, j, k)).sum();
            let sas = p.scale[i] * v * p.scale[j];
            assert!((llt - sas).abs() < 1e-12, "({i},{j}) of {n}");
        }
    }

    #[test]
    fn block_factor_on_an_indefinite_matrix_takes_the_scalar_shift() {
        // Lowering the diagonal until A is indefinite makes IC(0) break down
        // at zero shift; both factorisations must then agree on the shift
        // (it is relative to the diagonal, so invariant to the block form)
        // and on the preconditioner.
        let mut a = spd_block_matrix(3, 3);
        let lowest = (0..a.n_blocks())
            .map(|i| a.diagonal_block(i)[0][0])
            .fold(f64::INFINITY, f64::min);
        a.add_to_diagonal(&vec![-0.9 * lowest; a.dim()]).unwrap();
        let mut pb = IncompleteCholesky::new();
        pb.setup(&a).unwrap();
        let mut pc = IncompleteCholesky::new();
        pc.setup(&a.to_csr()).unwrap();
        assert!(pb.shift() >= 1e-3, "shift {}", pb.shift());
        assert_eq!(pb.shift(), pc.shift());
        let r = rhs(a.dim());
        let (mut zb, mut zc) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        pb.apply(&r, &mut zb);
        pc.apply(&r, &mut zc);
        assert!(rel_diff(&zb, &zc) < 1e-12);
    }

    #[test]
    fn non_finite_block_entries_are_an_error_wherever_they_sit() {
        // The block factorisation scans the matrix only after a failed
        // pivot: a NaN or infinity anywhere must still surface as NonFinite.
        let a = spd_block_matrix(3, 3);
        let slots = a.values().len();
        for (slot, value) in [(slots - 1, f64::NAN), (0, f64::INFINITY), (1, f64::NAN)] {
            let mut b = a.clone();
            b.values_mut()[slot][0][1] = value;
            let mut p = IncompleteCholesky::new();
            assert!(
                matches!(p.setup(&b), Err(SparseError::NonFinite { .. })),
                "slot {slot}"
            );
        }
    }

    /// A grid Laplacian with isotropic blocks `-c I` (and mass on the
    /// diagonal) on the pattern right / up / one diagonal: the other
    /// diagonal is dropped fill, and every fill block is a multiple of `I`.
    fn isotropic_grid(nx: usize, ny: usize) -> SymBlockMatrix {
        let pairs = grid_pairs(nx, ny);
        let n = nx * ny;
        let pattern = std::sync::Arc::new(crate::BlockPattern::new(n, pairs.clone()).unwrap());
        let mut a = SymBlockMatrix::new(pattern);
        let mut diag = vec![0.01; 3 * n];
        for (e, &(i, j)) in pairs.iter().enumerate() {
            let c = 1.0 + (e % 3) as f64;
            a.add_to_block(i, j, &crate::block::scale(&crate::block::IDENTITY, -c))
                .unwrap();
            for k in 0..3 {
                diag[3 * i + k] += c;
                diag[3 * j + k] += c;
            }
        }
        a.add_to_diagonal(&diag).unwrap();
        a
    }

    /// `|M^-1 (A e) - e| / |e|` for the translation `e` along axis `c`:
    /// zero when `M` keeps `A`'s row sums (Gustafsson's property).
    fn row_sum_error(p: &IncompleteCholesky, a: &SymBlockMatrix, c: usize) -> f64 {
        let n = a.dim();
        let e: Vec<f64> = (0..n).map(|k| if k % 3 == c { 1.0 } else { 0.0 }).collect();
        let mut ae = vec![0.0; n];
        a.mul_vec(&e, &mut ae).unwrap();
        let mut z = vec![0.0; n];
        p.apply(&ae, &mut z);
        rel_diff(&z, &e)
    }

    #[test]
    fn mic0_with_omega_one_keeps_the_row_sums_and_ic0_does_not() {
        // Gustafsson's property: M e = A e for the translations e, i.e.
        // M^-1 (A e) = e. IC(0) drops the fill and misses it.
        let a = isotropic_grid(5, 4);
        let mut mic = IncompleteCholesky::modified(1.0).unwrap();
        mic.setup(&a).unwrap();
        let mut ic = IncompleteCholesky::new();
        ic.setup(&a).unwrap();
        for c in 0..3 {
            assert!(row_sum_error(&mic, &a, c) < 1e-12, "MIC(0), direction {c}");
            assert!(row_sum_error(&ic, &a, c) > 1e-3, "IC(0), direction {c}");
        }
    }

    #[test]
    fn mic0_needs_a_quarter_fewer_iterations_on_a_stiff_grid() {
        // The reason it exists: on a stiff grid (small mass) PCG with
        // MIC(0) converges in clearly fewer iterations than with IC(0)
        // (the gap grows with the grid: O(h^-1/2) against O(h^-1)).
        let a = isotropic_grid(32, 32);
        let b: Vec<f64> = (0..a.dim()).map(|k| 1.0 + (k % 7) as f64).collect();
        let its = |p: &mut IncompleteCholesky| {
            p.setup(&a).unwrap();
            let mut x = vec![0.0; a.dim()];
            let mut ws = crate::CgWorkspace::new(a.dim());
            let info = crate::pcg(
                &a,
                &*p,
                &b,
                &mut x,
                &crate::CgParams::default(),
                &mut ws,
                None,
            )
            .unwrap();
            assert!(info.converged);
            info.iterations
        };
        let ic = its(&mut IncompleteCholesky::new());
        let mic = its(&mut IncompleteCholesky::modified(0.99).unwrap());
        assert!(4 * mic < 3 * ic, "MIC(0) {mic} vs IC(0) {ic} iterations");
    }

    #[test]
    fn mic0_rejects_bad_relaxations_and_scalar_matrices() {
        assert!(IncompleteCholesky::modified(1.5).is_err());
        assert!(IncompleteCholesky::modified(-0.1).is_err());
        assert!(IncompleteCholesky::modified(f64::NAN).is_err());
        let mut p = IncompleteCholesky::modified(0.5).unwrap();
        assert!(matches!(
            p.setup(&tridiagonal(4)),
            Err(SparseError::InvalidParameter { .. })
        ));
    }

    /// The two-domain order of the block factor ([`super::super::two_domain`]):
    /// the factor's row `new` is the matrix's row `order[new]`.
    fn two_domain_order(p: &IncompleteCholesky) -> Vec<usize> {
        match &p.source {
            Source::Block(f) => f.order().expect("the pattern splits into two domains"),
            _ => panic!("not a block factor"),
        }
    }

    /// `P a P^T` in CSR for the block order `order` (new block row `k` is
    /// old block row `order[k]`).
    fn permuted_csr(a: &SymBlockMatrix, order: &[usize]) -> sprs::CsMat<f64> {
        let mut new_of = vec![0; order.len()];
        for (new, &old) in order.iter().enumerate() {
            new_of[old] = new;
        }
        let at = |i: usize| 3 * new_of[i / 3] + i % 3;
        let mut t = sprs::TriMat::new((a.dim(), a.dim()));
        for (&v, (i, j)) in a.to_csr().iter() {
            t.add_triplet(at(i), at(j), v);
        }
        t.to_csr()
    }

    #[test]
    fn two_domain_block_factor_is_ic0_of_the_permuted_matrix() {
        // 64 x 40 particles (2 560 blocks): the factor takes the order
        // A, B, S. It must be the scalar IC(0) of P A P^T (an independent
        // routine, in the matrix's given order), and apply it in A's numbering.
        let a = spd_block_matrix(64, 40);
        let mut pb = IncompleteCholesky::new();
        pb.setup(&a).unwrap();
        let order = two_domain_order(&pb);
        assert!(order.iter().enumerate().any(|(new, &old)| new != old));
        let mut pc = IncompleteCholesky::new();
        pc.setup(&permuted_csr(&a, &order)).unwrap();
        let r = rhs(a.dim());
        let mut pr = vec![0.0; r.len()];
        for (new, &old) in order.iter().enumerate() {
            pr[3 * new..3 * new + 3].copy_from_slice(&r[3 * old..3 * old + 3]);
        }
        let (mut zb, mut zc) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        pb.apply(&r, &mut zb);
        pc.apply(&pr, &mut zc);
        let mut z = vec![0.0; r.len()];
        for (new, &old) in order.iter().enumerate() {
            z[3 * old..3 * old + 3].copy_from_slice(&zc[3 * new..3 * new + 3]);
        }
        assert!(rel_diff(&zb, &z) < 1e-12, "{}", rel_diff(&zb, &z));
        // And not the natural order's IC(0): the order is a different
        // preconditioner.
        let mut pn = IncompleteCholesky::new();
        pn.setup(&a.to_csr()).unwrap();
        pn.apply(&r, &mut z);
        assert!(rel_diff(&zb, &z) > 1e-6);
    }

    #[test]
    fn two_domain_mic0_keeps_the_row_sums() {
        // Gustafsson's property holds in any order: M^-1 (A e) = e.
        let a = isotropic_grid(64, 40);
        let mut mic = IncompleteCholesky::modified(1.0).unwrap();
        mic.setup(&a).unwrap();
        two_domain_order(&mic);
        for c in 0..3 {
            let err = row_sum_error(&mic, &a, c);
            assert!(err < 1e-11, "direction {c}: {err}");
        }
    }

    #[test]
    fn two_domain_sweeps_have_the_same_bits_on_any_thread_count() {
        let a = spd_block_matrix(64, 40);
        let n = a.dim();
        let q: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
        let run = |threads: usize| {
            crate::par::in_pool(threads, || {
                let mut p = IncompleteCholesky::modified(0.97).unwrap();
                p.setup(&a).unwrap();
                two_domain_order(&p);
                let mut r = rhs(n);
                let mut z = vec![f64::NAN; n];
                let sums = p.update_and_apply(0.3, &q, &mut r, &mut z);
                let mut z2 = vec![f64::NAN; n];
                p.apply(&r, &mut z2);
                (sums, r, z, z2)
            })
        };
        let one = run(1);
        assert_eq!(one.2, one.3, "the fused and the plain sweeps differ");
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
        assert!((one.0.0 - dot(&one.1, &one.1)).abs() < 1e-12 * one.0.0);
        assert!((one.0.1 - dot(&one.1, &one.2)).abs() < 1e-12 * one.0.1.abs());
        for threads in [2, 3] {
            let other = run(threads);
            assert_eq!(one.0.0.to_bits(), other.0.0.to_bits(), "{threads} threads");
            assert_eq!(one.0.1.to_bits(), other.0.1.to_bits(), "{threads} threads");
            assert_eq!(one.1, other.1, "{threads} threads");
            assert_eq!(one.2, other.2, "{threads} threads");
        }
    }

    #[test]
    fn fused_residual_update_equals_update_then_apply() {
        let a = spd_block_matrix(4, 3);
        let mut p = IncompleteCholesky::new();
        p.setup(&a).unwrap();
        let n = a.dim();
        let q: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
        let mut r = rhs(n);
        let mut r2 = r.clone();
        for (ri, qi) in r2.iter_mut().zip(&q) {
            *ri -= 0.3 * qi;
        }
        let (mut z, mut z2) = (vec![f64::NAN; n], vec![0.0; n]);
        let (rr, rz) = p.update_and_apply(0.3, &q, &mut r, &mut z);
        p.apply(&r2, &mut z2);
        assert!(rel_diff(&r, &r2) < 1e-15);
        assert!(rel_diff(&z, &z2) < 1e-15);
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
        assert!((rr - dot(&r2, &r2)).abs() < 1e-12 * rr);
        assert!((rz - dot(&r2, &z2)).abs() < 1e-12 * rz.abs());
    }

    #[test]
    fn indefinite_matrix_gets_a_reported_shift() {
        // Unit diagonal, off-diagonals of a matrix with a negative eigenvalue.
        let mut t = sprs::TriMat::new((3, 3));
        for i in 0..3 {
            t.add_triplet(i, i, 1.0);
        }
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            t.add_triplet(i, j, 0.9);
            t.add_triplet(j, i, 0.9);
        }
        t.add_triplet(1, 2, -1.8); // (1,2) = -0.9 after summing duplicates
        t.add_triplet(2, 1, -1.8);
        let mut p = IncompleteCholesky::new();
        p.setup(&t.to_csr()).unwrap();
        assert!(p.shift() >= 1e-3, "shift {}", p.shift());
        let r = [1.0, 2.0, 3.0];
        let mut z = [0.0; 3];
        p.apply(&r, &mut z);
        assert!(z.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn non_finite_matrix_is_an_error() {
        let mut t = sprs::TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, f64::NAN);
        let mut p = IncompleteCholesky::new();
        assert!(matches!(
            p.setup(&t.to_csr()),
            Err(SparseError::NonFinite { .. })
        ));
    }
}
