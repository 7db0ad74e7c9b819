//! What a scalar CSR matrix is before it becomes PCG's: finite and
//! symmetric ([`check_csr_symmetric`]), and how many unknowns each of its
//! nodes holds ([`detect_block_size`], [`is_block_pattern`]).

use crate::error::SparseError;

/// `Ok` when the square `sprs` matrix `a` is finite and symmetric: every
/// entry equals its transpose to `1e-12` of the largest entry (what the
/// symmetric solvers, PCG and the Cholesky factorisation, need).
///
/// # Errors
/// [`SparseError::NonFinite`] or [`SparseError::NotSymmetric`] naming the
/// first offending entry.
pub fn check_csr_symmetric(a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
    let data = a.data();
    // One pass for both: whether an entry is not finite, and the largest magnitude.
    let (finite, largest) = data.iter().fold((true, 0.0_f64), |(f, m), v| {
        (f && v.is_finite(), m.max(v.abs()))
    });
    if !finite {
        let k = data
            .iter()
            .position(|v| !v.is_finite())
            .expect("an entry is not finite");
        // The entry's position in the order `a.iter()` visits (storage order).
        let (_, (r, c)) = a.iter().nth(k).expect("k indexes a stored entry");
        return Err(SparseError::NonFinite {
            what: "matrix",
            index: Some(r * a.cols() + c),
        });
    }
    let tol = 1e-12 * largest;
    if a.rows() == a.cols() && a.is_csr() && csr_mirrors_agree(a, tol) {
        return Ok(());
    }
    // Not symmetric (or not square CSR): the first offending entry in
    // storage order, by a search per entry.
    for (&v, (r, c)) in a.iter() {
        let t = a.get(c, r).copied().unwrap_or(0.0);
        if (v - t).abs() > tol {
            return Err(SparseError::NotSymmetric { row: r, col: c });
        }
    }
    Ok(())
}

/// Whether every entry `a_rc` of the square CSR matrix `a` (rows sorted,
/// as sprs keeps them) lies within `tol` of its mirror `a_cr` (0 when not
/// stored), in one pass over the entries and no search.
///
/// Rows are visited in order; `next[c]` points at row `c`'s first entry
/// right of the diagonal not yet paired. Row `r`'s entries `(r, c)` with
/// `c < r` arrive in order of `c`, and row `c`'s entries right of the
/// diagonal are met in order of their column `r`, so each mirror is found
/// at `next[c]`: entries it skips have no mirror and must be within `tol`
/// of zero, as must those left over at the end.
fn csr_mirrors_agree(a: &sprs::CsMat<f64>, tol: f64) -> bool {
    let (indptr, indices, data) = (a.indptr(), a.indices(), a.data());
    let (start, end) = (|i: usize| indptr.index(i), |i: usize| indptr.index(i + 1));
    let mut next: Vec<usize> = (0..a.rows())
        .map(|i| start(i) + indices[start(i)..end(i)].partition_point(|&c| c <= i))
        .collect();
    for r in 0..a.rows() {
        for k in start(r)..end(r) {
            let c = indices[k];
            if c >= r {
                break;
            }
            let mut m = next[c];
            while m < end(c) && indices[m] < r {
                if data[m].abs() > tol {
                    return false;
                }
                m += 1;
            }
            let mirror = if m < end(c) && indices[m] == r {
                m += 1;
                data[m - 1]
            } else {
                0.0
            };
            next[c] = m;
            if (data[k] - mirror).abs() > tol {
                return false;
            }
        }
    }
    (0..a.rows()).all(|i| data[next[i]..end(i)].iter().all(|v| v.abs() <= tol))
}

/// The unknowns per node `B` of `a`'s sparsity pattern: 3 or 2 when the
/// pattern is one of nodes of `B` unknowns (node `I` owns rows and columns
/// `B I .. B I + B`) and every row of a node couples to the same nodes,
/// the structure of a vector-valued finite-element or mass-spring system;
/// else 1.
///
/// The test is on nodes, not on dense `B x B` blocks: writers drop exact
/// zeros, and vector-valued stiffness has them inside node blocks (the
/// x-y coupling of a node with itself and its horizontal and vertical
/// neighbours in bilinear 2D elasticity on a uniform grid, the out-of-plane
/// coupling of a flat cloth's springs), so pyamg's 2D elasticity fills 72%
/// of its 2x2 blocks and the 3D bar 70% of its 3x3 ones. A scalar stencil
/// coupling unknowns `i` and `i + 1` fails it. A flat cloth fails it too
/// (its z rows miss neighbours that its x and y rows couple to), and says 1. A pattern that passes for both 2 and 3 (a diagonal matrix, or
/// one of dense 6x6 blocks, where the two groupings chain rows `6 I .. 6 I
/// + 6` together) says nothing about which: ambiguous, so 1. See
/// [`is_block_pattern`] to test one `B`.
pub fn detect_block_size(a: &sprs::CsMat<f64>) -> usize {
    match (is_block_pattern(a, 3), is_block_pattern(a, 2)) {
        (true, false) => 3,
        (false, true) => 2,
        _ => 1,
    }
}

/// Whether `a` is square with a dimension divisible by `b >= 1` and every
/// row of each node of `b` unknowns couples to the same set of nodes (see
/// [`detect_block_size`]); every square pattern passes for 1.
pub fn is_block_pattern(a: &sprs::CsMat<f64>, b: usize) -> bool {
    let (rows, cols) = a.shape();
    if b == 0 || rows != cols || !rows.is_multiple_of(b) {
        return false;
    }
    if !a.is_csr() {
        return is_block_pattern(&a.to_csr(), b);
    }
    let (indptr, indices) = (a.indptr(), a.indices());
    // The nodes row `r` couples to, each once (sprs keeps a row's indices
    // sorted, so a node's columns are consecutive).
    let nodes = |r: usize| {
        let columns = &indices[indptr.index(r)..indptr.index(r + 1)];
        columns
            .iter()
            .enumerate()
            .filter(move |&(k, &c)| k == 0 || columns[k - 1] / b != c / b)
            .map(move |(_, &c)| c / b)
    };
    (0..rows)
        .step_by(b)
        .all(|first| (first + 1..first + b).all(|r| nodes(r).eq(nodes(first))))
}
