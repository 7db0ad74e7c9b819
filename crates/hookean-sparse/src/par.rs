//! Threads for the kernels (rayon), deterministic for a given thread count.
//!
//! The kernels run on whatever rayon pool they are called from: the global
//! one (all cores, or `RAYON_NUM_THREADS`), or one a caller installed with
//! [`rayon::ThreadPool::install`] (the `hookean` command's `--threads`).
//! Work is split at fixed points (a function of the size and the number of
//! threads, never of who finishes first) and partial sums are added in a
//! fixed tree order, so two runs with the same thread count give the same
//! bits. Small problems stay serial: below [`MIN_PARALLEL_BLOCKS`] block
//! rows the fork-join costs more than it saves.
//!
//! MIC(0)/IC(0) on 3x3 blocks runs its triangular solves on two threads
//! when the pattern splits into two domains and a separator (the order is
//! a function of the pattern alone: `precond/two_domain.rs`). What stays
//! serial: its factorisation, the scalar IC(0)'s solves (each row needs the
//! rows before it), SSOR's sweeps, and the direct solver.

use crate::transpose::{column_pointers, scatter_transpose, to_usize};
use rayon::prelude::*;

/// Block rows (3 unknowns each) below which a kernel does not fork:
/// about 64 KiB per vector of 3 doubles.
pub const MIN_PARALLEL_BLOCKS: usize = 2048;

/// Scalar entries per leaf of the fixed-size vector splits (a multiple of 3
/// and of 4, so leaves hold whole blocks and whole SIMD chunks).
const LEAF: usize = 3 * 4096;

/// The number of parts a kernel on `n_blocks` block rows splits into: one
/// per thread of the current rayon pool, or 1 (serial) for small problems.
#[inline]
pub fn parts_for(n_blocks: usize) -> usize {
    if n_blocks < MIN_PARALLEL_BLOCKS {
        1
    } else {
        rayon::current_num_threads()
    }
}

/// Runs `f` on matching chunks of `a`, `b` (mutable) and `c`, in parallel
/// for long vectors. For element-wise updates: the result does not depend
/// on the split.
///
/// # Panics
/// If the lengths differ.
pub(crate) fn for_each_chunk3(
    a: &mut [f64],
    b: &mut [f64],
    c: &[f64],
    f: impl Fn(&mut [f64], &mut [f64], &[f64]) + Sync + Send,
) {
    assert!(a.len() == b.len() && b.len() == c.len());
    if parts_for(a.len() / 3) <= 1 {
        f(a, b, c);
        return;
    }
    a.par_chunks_mut(LEAF)
        .zip(b.par_chunks_mut(LEAF))
        .zip(c.par_chunks(LEAF))
        .for_each(|((a, b), c)| f(a, b, c));
}

/// `sum_k leaf(range_k)` over the leaves of `0..len` (fixed [`LEAF`]-sized
/// ranges), added in a fixed binary-tree order: the same bits for every
/// thread count and schedule. Serial (one leaf) for short vectors.
pub(crate) fn tree_sum(len: usize, leaf: &(impl Fn(usize, usize) -> f64 + Sync)) -> f64 {
    if parts_for(len / 3) <= 1 {
        return leaf(0, len);
    }
    tree_sum_leaves(0, len.div_ceil(LEAF), len, leaf)
}

fn tree_sum_leaves(
    l0: usize,
    l1: usize,
    len: usize,
    leaf: &(impl Fn(usize, usize) -> f64 + Sync),
) -> f64 {
    if l1 - l0 == 1 {
        return leaf(l0 * LEAF, ((l0 + 1) * LEAF).min(len));
    }
    let mid = (l0 + l1) / 2;
    let (a, b) = rayon::join(
        || tree_sum_leaves(l0, mid, len, leaf),
        || tree_sum_leaves(mid, l1, len, leaf),
    );
    a + b
}

/// Two sums over matching fixed-size leaves of `a` and `b` (mutable, same
/// length): `leaf(offset, a_leaf, b_leaf)` returns the leaf's pair, and the
/// pairs are added in a fixed binary tree (as [`tree_sum`]). For fused
/// passes that update vectors and reduce them, e.g. CG's `r -= alpha q`,
/// `z = D^-1 r` with `r . r` and `r . z`.
///
/// # Panics
/// If the lengths differ.
pub(crate) fn tree_sum2_mut(
    a: &mut [f64],
    b: &mut [f64],
    leaf: &(impl Fn(usize, &mut [f64], &mut [f64]) -> (f64, f64) + Sync),
) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let len = a.len();
    if parts_for(len / 3) <= 1 {
        return leaf(0, a, b);
    }
    tree_sum2_leaves(0, len.div_ceil(LEAF), 0, a, b, leaf)
}

fn tree_sum2_leaves(
    l0: usize,
    l1: usize,
    offset: usize,
    a: &mut [f64],
    b: &mut [f64],
    leaf: &(impl Fn(usize, &mut [f64], &mut [f64]) -> (f64, f64) + Sync),
) -> (f64, f64) {
    if l1 - l0 == 1 {
        return leaf(offset, a, b);
    }
    let mid = (l0 + l1) / 2;
    let split = (mid - l0) * LEAF;
    let (a0, a1) = a.split_at_mut(split);
    let (b0, b1) = b.split_at_mut(split);
    let (x, y) = rayon::join(
        || tree_sum2_leaves(l0, mid, offset, a0, b0, leaf),
        || tree_sum2_leaves(mid, l1, offset + split, a1, b1, leaf),
    );
    (x.0 + y.0, x.1 + y.1)
}

/// The transpose's index of a symmetric matrix stored as its upper triangle
/// in CSR, for the threaded products: column `j`'s stored entries `(i, j)`,
/// `i < j`, are row `row[k]` at slot `slot[k]` for `k` in
/// `ptr[j]..ptr[j + 1]`, rows ascending. A part of rows `s..e` gathers
/// through it what the rows before `s` add to its rows, so no part writes
/// another's rows (the block and the scalar symmetric products).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct LowerIndex {
    pub(crate) ptr: Vec<usize>,
    pub(crate) row: Vec<u32>,
    pub(crate) slot: Vec<usize>,
}

impl LowerIndex {
    /// The index of the pattern `row_ptr` / `col` whose rows hold `skip`
    /// leading slots that are not strictly upper (1 for a diagonal stored
    /// first, 0 for the strict upper triangle), by counting sort: rows
    /// visited in increasing order leave every column's list sorted by row.
    pub(crate) fn of_upper<T: Copy + TryInto<usize>>(
        row_ptr: &[T],
        col: &[u32],
        skip: usize,
    ) -> Self {
        let n = row_ptr.len() - 1;
        let ptr = column_pointers(n, row_ptr, col, skip);
        let mut row = vec![0u32; ptr[n]];
        let mut slot = vec![0usize; ptr[n]];
        scatter_transpose(row_ptr, col, skip, &mut ptr.clone(), &mut row, |p, k| {
            slot[p] = k;
        });
        Self { ptr, row, slot }
    }
}

/// First row of part `t` of `parts` parts of a CSR pattern's rows with
/// about equal numbers of stored entries (`t = parts` gives `n`): a fixed
/// function of the pattern and `parts`, so a threaded kernel splits the same
/// way every call.
pub(crate) fn part_start<T: Copy + TryInto<usize>>(row_ptr: &[T], t: usize, parts: usize) -> usize {
    let n = row_ptr.len() - 1;
    if t >= parts {
        return n;
    }
    let target = to_usize(row_ptr[n]) * t / parts;
    row_ptr[..n].partition_point(|&p| to_usize(p) < target)
}

/// `leaf(t, part)` for the parts `t` of `0..parts` of `data`, part `t`
/// being `data[start(t)..start(t + 1)]` (`start(0) = 0`), halves under
/// [`rayon::join`], the results combined by `add` in a fixed tree order: the
/// threaded row-part kernels (the symmetric products, the contact filter)
/// do not depend on scheduling.
pub(crate) fn join_parts<T: Send, R: Send>(
    data: &mut [T],
    parts: usize,
    start: &(impl Fn(usize) -> usize + Sync),
    leaf: &(impl Fn(usize, &mut [T]) -> R + Sync),
    add: &(impl Fn(R, R) -> R + Sync),
) -> R {
    join_range(data, 0, parts, start, leaf, add)
}

fn join_range<T: Send, R: Send>(
    data: &mut [T],
    p0: usize,
    p1: usize,
    start: &(impl Fn(usize) -> usize + Sync),
    leaf: &(impl Fn(usize, &mut [T]) -> R + Sync),
    add: &(impl Fn(R, R) -> R + Sync),
) -> R {
    if p1 - p0 == 1 {
        return leaf(p0, data);
    }
    let mid = (p0 + p1) / 2;
    let (a, b) = data.split_at_mut(start(mid) - start(p0));
    let (x, y) = rayon::join(
        || join_range(a, p0, mid, start, leaf, add),
        || join_range(b, mid, p1, start, leaf, add),
    );
    add(x, y)
}

/// Runs `f` in a fresh rayon pool of `threads` threads (the tests' way to
/// compare thread counts).
#[cfg(test)]
pub(crate) fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tree_sum_is_the_sum_and_independent_of_the_pool() {
        let n = 3 * MIN_PARALLEL_BLOCKS * 5 + 7;
        let x: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 1013) as f64 * 1e-3 - 0.5)
            .collect();
        let leaf = |a: usize, b: usize| x[a..b].iter().sum::<f64>();
        let exact: f64 = x.iter().sum();
        let sums: Vec<f64> = [1, 2, 3]
            .iter()
            .map(|&t| in_pool(t, || tree_sum(n, &leaf)))
            .collect();
        assert!((sums[1] - exact).abs() <= 1e-9 * n as f64);
        // With one thread the kernel does not fork (one leaf over all of it);
        // with two or more the fixed tree gives the same bits.
        assert_eq!(sums[1].to_bits(), sums[2].to_bits());
    }

    #[test]
    fn tree_sum2_updates_every_entry_once_and_sums_in_a_fixed_order() {
        let n = 3 * MIN_PARALLEL_BLOCKS * 3 + 5;
        let run = |threads: usize| {
            in_pool(threads, || {
                let mut a = vec![1.0; n];
                let mut b: Vec<f64> = (0..n).map(|i| i as f64).collect();
                let s = tree_sum2_mut(&mut a, &mut b, &|at, a, b| {
                    let mut s = (0.0, 0.0);
                    for k in 0..a.len() {
                        a[k] += (at + k) as f64;
                        b[k] *= 0.5;
                        s.0 += a[k];
                        s.1 += b[k];
                    }
                    s
                });
                (a, b, s)
            })
        };
        let (a1, b1, s1) = run(1);
        let (a2, b2, s2) = run(2);
        let (_, _, s3) = run(3);
        assert_eq!((&a1, &b1), (&a2, &b2));
        assert!(a1.iter().enumerate().all(|(k, &v)| v == 1.0 + k as f64));
        let m = n as f64;
        assert!((s2.0 - (m + m * (m - 1.0) / 2.0)).abs() <= 1e-12 * m * m);
        assert!((s2.1 - m * (m - 1.0) / 4.0).abs() <= 1e-12 * m * m);
        assert!((s1.0 - s2.0).abs() <= 1e-12 * m * m);
        assert_eq!(
            (s2.0.to_bits(), s2.1.to_bits()),
            (s3.0.to_bits(), s3.1.to_bits())
        );
    }
}
