//! The storage a symmetric system takes for PCG: 3x3 blocks for nodes of 3
//! unknowns when the matrix allows them, else CSR with the unknowns per
//! node the multigrid and block Jacobi group; and where that number of
//! unknowns comes from.
//!
//! One rule for every caller that hands PCG a general sparse matrix (the
//! command line's `hookean solve --format auto`, the Python bindings).

use crate::cg::{CgCallback, CgInfo, CgParams, CgWorkspace, pcg};
use crate::error::SparseError;
use crate::matrix::{SymBlockMatrix, check_csr_symmetric};
use crate::precond::{AnyPreconditioner, PreconditionerSetup};
use crate::symcsr::SymCsrMatrix;

/// A square matrix in the storage PCG runs on.
///
/// ```
/// use hookean_sparse::{PcgMatrix, sprs::TriMat};
/// // The 1D Laplacian of 4 unknowns: a scalar stencil, no 3x3 blocks.
/// let mut t = TriMat::new((4, 4));
/// for i in 0..4 {
///     t.add_triplet(i, i, 2.0);
///     if i > 0 { t.add_triplet(i, i - 1, -1.0); t.add_triplet(i - 1, i, -1.0); }
/// }
/// let m = PcgMatrix::auto(t.to_csr(), 1);
/// assert_eq!((m.format(), m.block_size()), ("csr", 1));
/// ```
#[derive(Debug, Clone)]
pub enum PcgMatrix {
    /// Symmetric 3x3-block storage.
    Block(SymBlockMatrix),
    /// Plain CSR, with the unknowns per node multigrid groups into blocks;
    /// the preconditioners are built from `a`, and PCG's products use its
    /// upper triangle (`product`, [`SymCsrMatrix`]) when `a` is symmetric.
    Csr {
        /// The matrix, both triangles stored.
        a: sprs::CsMat<f64>,
        /// Unknowns per node (1, 2 or 3) for the multigrid.
        block_size: usize,
        /// The symmetric product, when `a` is symmetric and finite.
        product: Option<Box<SymCsrMatrix>>,
    },
}

impl PcgMatrix {
    /// CSR storage of `a`, with the symmetric product when `a` is symmetric.
    pub fn csr(a: sprs::CsMat<f64>, block_size: usize) -> Self {
        let product = SymCsrMatrix::from_csr(&a).ok().map(Box::new);
        PcgMatrix::Csr {
            a,
            block_size,
            product,
        }
    }

    /// The storage `hookean solve --format auto` picks: 3x3 blocks when
    /// the system has 3 unknowns per node (`block_size`, from a flag, a
    /// near-nullspace, coordinates or the pattern) and `a` allows them
    /// ([`SymBlockMatrix::from_csr`]), else CSR with `block_size`. A scalar
    /// matrix keeps scalar storage whatever its size.
    pub fn auto(a: sprs::CsMat<f64>, block_size: usize) -> Self {
        if block_size != 3 {
            return Self::csr(a, block_size);
        }
        match SymBlockMatrix::from_csr(&a) {
            Ok(m) => PcgMatrix::Block(m),
            Err(_) => Self::csr(a, block_size),
        }
    }

    /// The unknowns per node: 3 on block storage.
    pub fn block_size(&self) -> usize {
        match self {
            PcgMatrix::Block(_) => 3,
            PcgMatrix::Csr { block_size, .. } => *block_size,
        }
    }

    /// Whether `other` is stored on the same pattern (the same 3x3 blocks,
    /// or the same CSR rows and columns): what a preconditioner built from
    /// `self` needs to be refilled from `other`.
    pub fn same_pattern(&self, other: &PcgMatrix) -> bool {
        match (self, other) {
            (PcgMatrix::Block(a), PcgMatrix::Block(b)) => a.pattern() == b.pattern(),
            (PcgMatrix::Csr { a, .. }, PcgMatrix::Csr { a: b, .. }) => {
                a.shape() == b.shape()
                    && a.indptr().raw_storage() == b.indptr().raw_storage()
                    && a.indices() == b.indices()
            }
            _ => false,
        }
    }

    /// The storage's name: `sym-block-3x3` or `csr`.
    pub fn format(&self) -> &'static str {
        match self {
            PcgMatrix::Block(_) => "sym-block-3x3",
            PcgMatrix::Csr { .. } => "csr",
        }
    }

    /// The number of rows.
    pub fn dim(&self) -> usize {
        match self {
            PcgMatrix::Block(m) => m.dim(),
            PcgMatrix::Csr { a, .. } => a.rows(),
        }
    }

    /// Sets `p` up (or refills it) from this matrix.
    ///
    /// # Errors
    /// As the preconditioner's [`PreconditionerSetup::setup`].
    pub fn setup(&self, p: &mut AnyPreconditioner) -> Result<(), SparseError> {
        match self {
            PcgMatrix::Block(m) => p.setup(m),
            PcgMatrix::Csr { a, .. } => p.setup(a),
        }
    }

    /// [`pcg`] on this matrix (the symmetric product on CSR).
    ///
    /// # Errors
    /// [`SparseError::NotSymmetric`] / [`SparseError::NonFinite`] for a CSR
    /// matrix that is not symmetric, else as [`pcg`].
    pub fn pcg(
        &self,
        p: &AnyPreconditioner,
        b: &[f64],
        x: &mut [f64],
        params: &CgParams,
        workspace: &mut CgWorkspace,
        callback: Option<CgCallback<'_>>,
    ) -> Result<CgInfo, SparseError> {
        match self {
            PcgMatrix::Block(m) => pcg(m, p, b, x, params, workspace, callback),
            PcgMatrix::Csr {
                product: Some(s), ..
            } => pcg(&**s, p, b, x, params, workspace, callback),
            PcgMatrix::Csr { a, .. } => {
                check_csr_symmetric(a)?;
                pcg(a, p, b, x, params, workspace, callback)
            }
        }
    }
}

/// The unknowns per node `d` a near-nullspace implies: its first vector (a
/// translation along the first axis, or the constant) is non-zero exactly
/// at the entries `i` with `i % d == 0`. 1 for a vector without zeros (the
/// constant of a scalar problem); `None` for another pattern.
///
/// ```
/// use hookean_sparse::nullspace_block_size;
/// assert_eq!(nullspace_block_size(&[vec![1.0; 6]]), Some(1));
/// assert_eq!(nullspace_block_size(&[vec![1.0, 0.0, 1.0, 0.0]]), Some(2));
/// assert_eq!(nullspace_block_size(&[]), None);
/// ```
pub fn nullspace_block_size(nullspace: &[Vec<f64>]) -> Option<usize> {
    let first = nullspace.first()?;
    (1..=3).find(|&d| {
        first.len().is_multiple_of(d)
            && first
                .iter()
                .enumerate()
                .all(|(i, v)| (*v != 0.0) == i.is_multiple_of(d))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rigid-body modes of n nodes in `d` dimensions at coordinates
    /// `(i, 2 i, ...)`: d translations, then rotations (the first vector is
    /// the translation along x).
    fn rigid_modes(n: usize, d: usize) -> Vec<Vec<f64>> {
        let mut modes: Vec<Vec<f64>> = (0..d)
            .map(|c| (0..n * d).map(|i| f64::from(i % d == c)).collect())
            .collect();
        // The rotation in the xy plane: (-y, x, 0).
        modes.push(
            (0..n * d)
                .map(|i| match i % d {
                    0 => -2.0 * (i / d) as f64 - 1.0,
                    1 => (i / d) as f64 + 1.0,
                    _ => 0.0,
                })
                .collect(),
        );
        modes
    }

    #[test]
    fn the_first_translation_gives_the_unknowns_per_node() {
        assert_eq!(nullspace_block_size(&[vec![1.0; 12]]), Some(1));
        assert_eq!(nullspace_block_size(&rigid_modes(5, 2)), Some(2));
        assert_eq!(nullspace_block_size(&rigid_modes(5, 3)), Some(3));
        // A vector with zeros in no period: no answer.
        assert_eq!(
            nullspace_block_size(&[vec![1.0, 0.0, 0.0, 0.0, 1.0, 1.0]]),
            None
        );
        assert_eq!(nullspace_block_size(&[]), None);
    }

    /// The identity of 6 unknowns: 3x3 blocks only for nodes of 3
    /// unknowns; scalar and 2-unknown nodes keep CSR, n divisible by 3 or not.
    #[test]
    fn auto_takes_blocks_only_for_three_unknowns_per_node() {
        let eye = sprs::CsMat::<f64>::eye(6);
        assert_eq!(PcgMatrix::auto(eye.clone(), 3).format(), "sym-block-3x3");
        for b in [1, 2] {
            let m = PcgMatrix::auto(eye.clone(), b);
            assert_eq!((m.format(), m.block_size()), ("csr", b));
        }
        // 5 rows: no 3x3 blocks even for 3.
        assert_eq!(PcgMatrix::auto(sprs::CsMat::eye(5), 3).format(), "csr");
    }

    /// Same pattern: new values on the same entries (either storage); not:
    /// an entry more, or the other storage of the same matrix.
    #[test]
    fn same_pattern_compares_the_stored_entries() {
        let tridiagonal = |d: f64, extra: bool| {
            let mut t = sprs::TriMat::new((9, 9));
            for i in 0..9 {
                t.add_triplet(i, i, d);
                if i > 0 {
                    t.add_triplet(i, i - 1, -1.0);
                    t.add_triplet(i - 1, i, -1.0);
                }
            }
            // Nodes 0 and 2 (rows 0..3, 6..9) coupled: a new 3x3 block too.
            if extra {
                t.add_triplet(0, 8, -0.5);
                t.add_triplet(8, 0, -0.5);
            }
            t.to_csr::<usize>()
        };
        for b in [3, 1] {
            let a = PcgMatrix::auto(tridiagonal(4.0, false), b);
            assert!(a.same_pattern(&PcgMatrix::auto(tridiagonal(9.0, false), b)));
            assert!(!a.same_pattern(&PcgMatrix::auto(tridiagonal(4.0, true), b)));
        }
        let block = PcgMatrix::auto(tridiagonal(4.0, false), 3);
        let csr = PcgMatrix::auto(tridiagonal(4.0, false), 1);
        assert_eq!((block.format(), csr.format()), ("sym-block-3x3", "csr"));
        assert!(!block.same_pattern(&csr));
    }
}
