//! The counting-sort transpose of a CSR pattern (Gustavson 1978, "Two fast
//! algorithms for sparse matrices: multiplication and permuted
//! transposition"): column counts, their prefix sums as the transpose's row
//! pointers, then one pass over the rows in order, so every row of the
//! transpose comes out sorted whatever the order of the columns within the
//! input's rows. Shared by the multigrid's patterns (`A^T`, the symbolic
//! product's sort) and the symmetric products' transposed index
//! ([`LowerIndex`](crate::par::LowerIndex)).

/// A row pointer (`usize`, or `u32` where the storage is checked to fit) as
/// a `usize`.
#[inline(always)]
pub(crate) fn to_usize<T: TryInto<usize>>(v: T) -> usize {
    v.try_into().unwrap_or(usize::MAX)
}

/// The slots of row `i` of the pattern `row_ptr`, without its first `skip`
/// (a diagonal stored first: 1; else 0).
#[inline(always)]
fn row_slots<T: Copy + TryInto<usize>>(
    row_ptr: &[T],
    i: usize,
    skip: usize,
) -> std::ops::Range<usize> {
    to_usize(row_ptr[i]) + skip..to_usize(row_ptr[i + 1])
}

/// The row pointers of the transpose of the pattern `(row_ptr, col)` with
/// `ncols` columns (each row's first `skip` slots left out): the prefix
/// sums of the column counts.
pub(crate) fn column_pointers<T: Copy + TryInto<usize>>(
    ncols: usize,
    row_ptr: &[T],
    col: &[u32],
    skip: usize,
) -> Vec<usize> {
    let mut ptr = vec![0usize; ncols + 1];
    for i in 0..row_ptr.len() - 1 {
        for &c in &col[row_slots(row_ptr, i, skip)] {
            ptr[c as usize + 1] += 1;
        }
    }
    for j in 0..ncols {
        ptr[j + 1] += ptr[j];
    }
    ptr
}

/// The transpose of the pattern `(row_ptr, col)` (each row's first `skip`
/// slots left out) into `col_t`, `next` holding on entry the transpose's
/// row pointers ([`column_pointers`]); rows are visited in order, so every
/// row of the transpose is sorted. `moved(p, k)`: slot `p` of the
/// transpose is slot `k` of the input.
#[inline(always)]
pub(crate) fn scatter_transpose<T: Copy + TryInto<usize>>(
    row_ptr: &[T],
    col: &[u32],
    skip: usize,
    next: &mut [usize],
    col_t: &mut [u32],
    mut moved: impl FnMut(usize, usize),
) {
    for i in 0..row_ptr.len() - 1 {
        for k in row_slots(row_ptr, i, skip) {
            let j = col[k] as usize;
            let p = next[j];
            next[j] += 1;
            col_t[p] = i as u32;
            moved(p, k);
        }
    }
}
