//! The identity, diagonal (Jacobi, eq. 53) and block-diagonal (one block
//! per node of 1, 2 or 3 unknowns) preconditioners.

use super::{Preconditioner, PreconditionerSetup, square_dim};
use crate::block::{self, Block3};
use crate::error::SparseError;
use crate::matrix::SymBlockMatrix;

/// No preconditioning: `z = r`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Identity;

impl Preconditioner for Identity {
    fn dim(&self) -> Option<usize> {
        None
    }
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
    }
}

impl<A: ?Sized> PreconditionerSetup<A> for Identity {
    fn setup(&mut self, _a: &A) -> Result<(), SparseError> {
        Ok(())
    }
}

/// Diagonal scaling `M = diag(A)` (the tutorial's eq. 53; Baraff-Witkin's choice).
#[derive(Debug, Clone, Default)]
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// An empty preconditioner; call [`setup`](PreconditionerSetup::setup) before use.
    pub fn new() -> Self {
        Self::default()
    }

    fn store(&mut self, n: usize, diag: impl Fn(usize) -> f64) -> Result<(), SparseError> {
        self.inv_diag.resize(n, 0.0);
        for i in 0..n {
            let d = diag(i);
            if !(d > 0.0 && d.is_finite()) {
                return Err(SparseError::NonPositiveDiagonal {
                    preconditioner: "Jacobi",
                    row: i,
                    value: d,
                });
            }
            self.inv_diag[i] = 1.0 / d;
        }
        Ok(())
    }
}

impl Preconditioner for Jacobi {
    fn dim(&self) -> Option<usize> {
        Some(self.inv_diag.len())
    }
    #[inline]
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        for ((z, r), d) in z.iter_mut().zip(r).zip(&self.inv_diag) {
            *z = r * d;
        }
    }
    #[inline]
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        let mut acc = 0.0;
        for ((z, r), d) in z.iter_mut().zip(r).zip(&self.inv_diag) {
            *z = r * d;
            acc += r * *z;
        }
        acc
    }
    #[inline]
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        // Long vectors: fixed leaves on the rayon pool, sums in a fixed tree.
        crate::par::tree_sum2_mut(r, z, &|at, r, z| {
            let end = at + r.len();
            jacobi_update(alpha, &q[at..end], &self.inv_diag[at..end], r, z)
        })
    }
}

/// Jacobi's fused CG pass on one range: `r -= alpha q`, `z = D^-1 r`;
/// returns `(r . r, r . z)`.
#[inline]
fn jacobi_update(
    alpha: f64,
    q: &[f64],
    inv_diag: &[f64],
    r: &mut [f64],
    z: &mut [f64],
) -> (f64, f64) {
    // Four independent partial sums keep the two reductions from
    // serialising the pass on floating-point add latency.
    let n = r.len();
    let (r4, _) = r.as_chunks_mut::<4>();
    let (z4, _) = z.as_chunks_mut::<4>();
    let (q4, _) = q.as_chunks::<4>();
    let (d4, _) = inv_diag.as_chunks::<4>();
    let mut rr = [0.0; 4];
    let mut rz = [0.0; 4];
    for (((r, z), q), d) in r4.iter_mut().zip(z4.iter_mut()).zip(q4).zip(d4) {
        for l in 0..4 {
            let ri = r[l] - alpha * q[l];
            r[l] = ri;
            let zi = ri * d[l];
            z[l] = zi;
            rr[l] += ri * ri;
            rz[l] += ri * zi;
        }
    }
    let (mut rr, mut rz) = (
        (rr[0] + rr[1]) + (rr[2] + rr[3]),
        (rz[0] + rz[1]) + (rz[2] + rz[3]),
    );
    for i in n - n % 4..n {
        let ri = r[i] - alpha * q[i];
        r[i] = ri;
        let zi = ri * inv_diag[i];
        z[i] = zi;
        rr += ri * ri;
        rz += ri * zi;
    }
    (rr, rz)
}

impl PreconditionerSetup<SymBlockMatrix> for Jacobi {
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        self.store(a.dim(), |i| a.diagonal_block(i / 3)[i % 3][i % 3])
    }
}

impl PreconditionerSetup<sprs::CsMat<f64>> for Jacobi {
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let n = square_dim(a)?;
        self.store(n, |i| a.get(i, i).copied().unwrap_or(0.0))
    }
}

/// Block-diagonal preconditioner: the diagonal blocks of `A` of one node
/// each, inverted (a particle's 3x3 block couples x, y and z, which Jacobi
/// does not).
///
/// A node has `B` unknowns ([`with_block_size`](Self::with_block_size)):
/// 3 on [`SymBlockMatrix`] storage, and on CSR the system's unknowns per
/// node (1, 2 or 3; node `i` owns rows `B i .. B i + B`), the number the
/// multigrid groups by ([`AmgOptions::block_size`](super::AmgOptions::block_size)).
/// With `B = 1` it is [`Jacobi`] that also accepts negative diagonals.
///
/// ```
/// use hookean_sparse::{BlockJacobi, Preconditioner, PreconditionerSetup, sprs::TriMat};
/// // Two nodes of 2 unknowns, blocks [[2, 1], [1, 2]] and [[4, 0], [0, 1]].
/// let mut t = TriMat::new((4, 4));
/// for (r, c, v) in [(0, 0, 2.0), (0, 1, 1.0), (1, 0, 1.0), (1, 1, 2.0), (2, 2, 4.0), (3, 3, 1.0)] {
///     t.add_triplet(r, c, v);
/// }
/// let mut p = BlockJacobi::with_block_size(2).unwrap();
/// p.setup(&t.to_csr()).unwrap();
/// let mut z = [0.0; 4];
/// p.apply(&[3.0, 3.0, 4.0, 1.0], &mut z);
/// assert_eq!(z, [1.0, 1.0, 1.0, 1.0]);
/// ```
#[derive(Debug, Clone)]
pub struct BlockJacobi {
    inverses: NodeInverses,
}

/// The inverted diagonal blocks, `B x B` each.
#[derive(Debug, Clone)]
enum NodeInverses {
    One(Vec<[[f64; 1]; 1]>),
    Two(Vec<[[f64; 2]; 2]>),
    Three(Vec<Block3>),
}

impl Default for BlockJacobi {
    /// 3 unknowns per node.
    fn default() -> Self {
        Self {
            inverses: NodeInverses::Three(Vec::new()),
        }
    }
}

impl BlockJacobi {
    /// An empty preconditioner of 3x3 blocks; call
    /// [`setup`](PreconditionerSetup::setup) before use.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty preconditioner of nodes of `block_size` unknowns on CSR
    /// matrices (block storage has 3 whatever it is).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] unless `block_size` is 1, 2 or 3.
    pub fn with_block_size(block_size: usize) -> Result<Self, SparseError> {
        let inverses = match block_size {
            1 => NodeInverses::One(Vec::new()),
            2 => NodeInverses::Two(Vec::new()),
            3 => NodeInverses::Three(Vec::new()),
            b => {
                return Err(SparseError::InvalidParameter {
                    name: "block_size",
                    message: format!("{b} is not 1, 2 or 3"),
                });
            }
        };
        Ok(Self { inverses })
    }

    /// Nodes of 3 unknowns from now on (block storage, whatever was asked).
    fn make_three(&mut self) {
        if !matches!(self.inverses, NodeInverses::Three(_)) {
            self.inverses = NodeInverses::Three(Vec::new());
        }
    }

    /// Sets up from the CSR copy `a` of a matrix of 3x3 blocks in another
    /// storage (nodes of 3 whatever was asked, as on [`SymBlockMatrix`]).
    pub(crate) fn setup_three_from_csr(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        self.make_three();
        self.setup(a)
    }

    /// The unknowns per node on CSR matrices: 1, 2 or 3.
    pub fn block_size(&self) -> usize {
        match self.inverses {
            NodeInverses::One(_) => 1,
            NodeInverses::Two(_) => 2,
            NodeInverses::Three(_) => 3,
        }
    }
}

/// Inverts the `n` blocks `blk(i)` into `inv` (resized, so a refill of the
/// same size does not allocate). A block of `B < 3` unknowns is inverted as
/// the 3x3 block with its largest entry `s` on the rest of the diagonal,
/// so [`block::inverse`]'s test, `|det| <= 1e-14 s^3`, becomes
/// `|det| <= 1e-14 s^B` on the block itself.
fn invert_nodes<const B: usize>(
    inv: &mut Vec<[[f64; B]; B]>,
    n: usize,
    blk: impl Fn(usize) -> [[f64; B]; B],
) -> Result<(), SparseError> {
    inv.resize(n, [[0.0; B]; B]);
    for (i, slot) in inv.iter_mut().enumerate() {
        let b = blk(i);
        let s = b.iter().flatten().fold(0.0_f64, |m, v| m.max(v.abs()));
        let mut padded = [[0.0; 3], [0.0; 3], [0.0; 3]];
        for (k, row) in padded.iter_mut().enumerate() {
            row[k] = s;
        }
        for r in 0..B {
            padded[r][..B].copy_from_slice(&b[r]);
        }
        let inverse = block::inverse(&padded).ok_or_else(|| SparseError::SingularBlock {
            block: i,
            determinant: if s > 0.0 {
                block::determinant(&padded) / s.powi(3 - B as i32)
            } else {
                0.0
            },
        })?;
        for r in 0..B {
            slot[r].copy_from_slice(&inverse[r][..B]);
        }
    }
    Ok(())
}

/// `z = M^-1 r` node by node; returns `r . z`.
#[inline]
fn apply_nodes<const B: usize>(inv: &[[[f64; B]; B]], r: &[f64], z: &mut [f64]) -> f64 {
    let (r, _) = r.as_chunks::<B>();
    let (z, _) = z.as_chunks_mut::<B>();
    let mut acc = 0.0;
    for ((z, r), m) in z.iter_mut().zip(r).zip(inv) {
        // Left to right, as `block::mul_vec`, and the node's share of
        // `r . z` summed before it joins `acc` (the bits of 3x3 blocks).
        for k in 0..B {
            let mut s = m[k][0] * r[0];
            for j in 1..B {
                s += m[k][j] * r[j];
            }
            z[k] = s;
        }
        let mut node = r[0] * z[0];
        for k in 1..B {
            node += r[k] * z[k];
        }
        acc += node;
    }
    acc
}

impl Preconditioner for BlockJacobi {
    fn dim(&self) -> Option<usize> {
        Some(match &self.inverses {
            NodeInverses::One(v) => v.len(),
            NodeInverses::Two(v) => 2 * v.len(),
            NodeInverses::Three(v) => 3 * v.len(),
        })
    }
    #[inline]
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        self.apply_dot(r, z);
    }
    #[inline]
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        match &self.inverses {
            NodeInverses::One(v) => apply_nodes(v, r, z),
            NodeInverses::Two(v) => apply_nodes(v, r, z),
            NodeInverses::Three(v) => apply_nodes(v, r, z),
        }
    }
}

impl PreconditionerSetup<SymBlockMatrix> for BlockJacobi {
    /// The 3x3 diagonal blocks (block storage has 3 unknowns per node).
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        self.make_three();
        match &mut self.inverses {
            NodeInverses::Three(inv) => invert_nodes(inv, a.n_blocks(), |i| *a.diagonal_block(i)),
            _ => Ok(()),
        }
    }
}

/// The diagonal block of node `i` of `a`, `B x B` (absent entries 0).
fn csr_block<const B: usize>(a: &sprs::CsMat<f64>, i: usize) -> [[f64; B]; B] {
    let mut b = [[0.0; B]; B];
    for (r, row) in b.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = a.get(B * i + r, B * i + c).copied().unwrap_or(0.0);
        }
    }
    b
}

impl PreconditionerSetup<sprs::CsMat<f64>> for BlockJacobi {
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let n = square_dim(a)?;
        let b = self.block_size();
        if !n.is_multiple_of(b) {
            return Err(if b == 3 {
                SparseError::NotBlockAligned { dim: n }
            } else {
                SparseError::InvalidParameter {
                    name: "block_size",
                    message: format!("the dimension {n} is not a multiple of the block size {b}"),
                }
            });
        }
        match &mut self.inverses {
            NodeInverses::One(v) => invert_nodes(v, n, |i| csr_block::<1>(a, i)),
            NodeInverses::Two(v) => invert_nodes(v, n / 2, |i| csr_block::<2>(a, i)),
            NodeInverses::Three(v) => invert_nodes(v, n / 3, |i| csr_block::<3>(a, i)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testutil::*;
    use super::*;

    #[test]
    fn jacobi_divides_by_the_diagonal() {
        let a = spd_block_matrix(3, 2);
        let d = dense(&a);
        let r = rhs(a.dim());
        for csr in [false, true] {
            let mut p = Jacobi::new();
            if csr {
                p.setup(&a.to_csr()).unwrap();
            } else {
                p.setup(&a).unwrap();
            }
            let mut z = vec![0.0; r.len()];
            let rz = p.apply_dot(&r, &mut z);
            let mut expected_rz = 0.0;
            for i in 0..r.len() {
                approx::assert_abs_diff_eq!(z[i], r[i] / d[i][i], epsilon = 1e-15);
                expected_rz += r[i] * r[i] / d[i][i];
            }
            approx::assert_relative_eq!(rz, expected_rz, max_relative = 1e-12);
        }
    }

    #[test]
    fn block_jacobi_solves_each_diagonal_block() {
        let a = spd_block_matrix(2, 3);
        let d = dense(&a);
        let r = rhs(a.dim());
        for csr in [false, true] {
            let mut p = BlockJacobi::new();
            if csr {
                p.setup(&a.to_csr()).unwrap();
            } else {
                p.setup(&a).unwrap();
            }
            let mut z = vec![0.0; r.len()];
            p.apply(&r, &mut z);
            for i in 0..a.n_blocks() {
                let blk: Vec<Vec<f64>> = (0..3)
                    .map(|rr| (0..3).map(|c| d[3 * i + rr][3 * i + c]).collect())
                    .collect();
                let expected = dense_solve(&blk, &r[3 * i..3 * i + 3]);
                assert!(rel_diff(&z[3 * i..3 * i + 3], &expected) < 1e-13);
            }
        }
    }

    /// On CSR, nodes of 1, 2 and 3 unknowns of the same 18 x 18 matrix:
    /// each node's block solved (against a dense solve of it).
    #[test]
    fn block_jacobi_solves_each_node_of_its_block_size() {
        let a = spd_block_matrix(2, 3);
        let d = dense(&a);
        let r = rhs(a.dim());
        for b in 1..=3 {
            let mut p = BlockJacobi::with_block_size(b).unwrap();
            p.setup(&a.to_csr()).unwrap();
            assert_eq!((p.block_size(), p.dim()), (b, Some(a.dim())));
            let mut z = vec![0.0; r.len()];
            let rz = p.apply_dot(&r, &mut z);
            for i in 0..a.dim() / b {
                let blk: Vec<Vec<f64>> = (0..b)
                    .map(|rr| (0..b).map(|c| d[b * i + rr][b * i + c]).collect())
                    .collect();
                let expected = dense_solve(&blk, &r[b * i..b * i + b]);
                assert!(rel_diff(&z[b * i..b * i + b], &expected) < 1e-13, "b = {b}");
            }
            let dot: f64 = r.iter().zip(&z).map(|(r, z)| r * z).sum();
            approx::assert_relative_eq!(rz, dot, max_relative = 1e-12);
        }
        // Block storage has 3 unknowns per node whatever was asked.
        let mut p = BlockJacobi::with_block_size(2).unwrap();
        p.setup(&a).unwrap();
        assert_eq!(p.block_size(), 3);
        assert!(BlockJacobi::with_block_size(4).is_err());
    }

    /// A tiny scale is no singularity: the 2x2 block 1e-20 [[2, 1], [1, 2]]
    /// inverts; the singular [[1, 1], [1, 1]] does not (determinant 0).
    #[test]
    fn small_blocks_are_singular_relative_to_their_size() {
        let block = |v: [[f64; 2]; 2]| {
            let mut t = sprs::TriMat::new((2, 2));
            for (r, row) in v.iter().enumerate() {
                for (c, x) in row.iter().enumerate() {
                    t.add_triplet(r, c, *x);
                }
            }
            t.to_csr()
        };
        let mut p = BlockJacobi::with_block_size(2).unwrap();
        p.setup(&block([[2e-20, 1e-20], [1e-20, 2e-20]])).unwrap();
        let mut z = [0.0; 2];
        p.apply(&[3e-20, 3e-20], &mut z);
        assert!(rel_diff(&z, &[1.0, 1.0]) < 1e-14, "{z:?}");
        assert_eq!(
            p.setup(&block([[1.0, 1.0], [1.0, 1.0]])),
            Err(SparseError::SingularBlock {
                block: 0,
                determinant: 0.0
            })
        );
        assert!(matches!(
            BlockJacobi::with_block_size(2)
                .unwrap()
                .setup(&sprs::CsMat::eye(5)),
            Err(SparseError::InvalidParameter {
                name: "block_size",
                ..
            })
        ));
    }

    #[test]
    fn non_positive_diagonal_and_singular_block_are_errors() {
        let mut t = sprs::TriMat::new((3, 3));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, -2.0);
        t.add_triplet(2, 2, 1.0);
        let m = t.to_csr();
        assert_eq!(
            Jacobi::new().setup(&m),
            Err(SparseError::NonPositiveDiagonal {
                preconditioner: "Jacobi",
                row: 1,
                value: -2.0
            })
        );
        let mut t = sprs::TriMat::new((3, 3));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, 1.0);
        let m = t.to_csr();
        assert!(matches!(
            BlockJacobi::new().setup(&m),
            Err(SparseError::SingularBlock { block: 0, .. })
        ));
        let mut t = sprs::TriMat::new((4, 4));
        t.add_triplet(0, 0, 1.0);
        assert_eq!(
            BlockJacobi::new().setup(&t.to_csr()),
            Err(SparseError::NotBlockAligned { dim: 4 })
        );
    }
}
