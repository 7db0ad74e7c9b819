//! Row-parallel loops of the multigrid kernels (rayon).
//!
//! Every kernel of the hierarchy writes only its own rows and computes each
//! row with the same sequential arithmetic whatever the split, so results
//! are bit-for-bit identical for any thread count (1 included). Work is split
//! by [`rayon::join`] down to [`ROWS_PER_TASK`] rows (no heap allocation);
//! smaller matrices, and every matrix when rayon has one thread, run on the
//! calling thread. [`install`] enters the thread pool once for a whole
//! V-cycle or set-up, so the kernels inside do not each pay the hand-over
//! from a thread outside the pool.
//!
//! The hottest kernels are [`RowKernel`]s run by [`kernel_rows`]: each
//! task's run of rows is compiled for the best instruction set of the CPU,
//! picked at run time (AVX2 and FMA on x86-64 when present, by
//! `pulp::Arch::dispatch`), so the 3x3 block products and the `f32 -> f64`
//! loads get 256-bit registers. The arithmetic is the same sequence of IEEE
//! operations on every instruction set (Rust never contracts `a * b + c`
//! into a fused multiply-add, and a vector lane computes what the scalar
//! code would), so the results do not depend on the machine either.

use rayon::{current_num_threads, join};

/// Runs `f` inside rayon's pool (one hand-over for all the kernels `f`
/// calls), or directly when the pool has one thread or we are already in it.
pub(crate) fn install<R: Send, F: FnOnce() -> R + Send>(f: F) -> R {
    if current_num_threads() == 1 || rayon::current_thread_index().is_some() {
        f()
    } else {
        let mut out = None;
        rayon::scope(|_| out = Some(f()));
        out.expect("the scope ran f")
    }
}

fn sequential(rows: usize) -> bool {
    rows <= ROWS_PER_TASK || current_num_threads() == 1
}

/// Rows per rayon task: below this a level's kernel runs sequentially (the
/// coarse levels, whose work is smaller than a task's overhead).
pub(crate) const ROWS_PER_TASK: usize = 1024;

/// `f(i, &mut out[i])` for every row `i`, split across threads.
pub(crate) fn rows<T: Send, F: Fn(usize, &mut T) + Sync>(out: &mut [T], f: &F) {
    rows_from(0, out, f);
}

fn rows_from<T: Send, F: Fn(usize, &mut T) + Sync>(first: usize, out: &mut [T], f: &F) {
    if sequential(out.len()) {
        for (i, y) in out.iter_mut().enumerate() {
            f(first + i, y);
        }
    } else {
        let mid = out.len() / 2;
        let (lo, hi) = out.split_at_mut(mid);
        join(|| rows_from(first, lo, f), || rows_from(first + mid, hi, f));
    }
}

/// One row of a kernel run by [`kernel_rows`]. `row` is to be marked
/// `#[inline(always)]`: then it is compiled inside the loop that
/// [`kernel_rows`] dispatches to the CPU's instruction set (a closure would
/// be called, compiled for the baseline, from both the baseline and the
/// AVX2 loop).
pub(crate) trait RowKernel<T>: Sync {
    /// Row `i`'s output `out`.
    fn row(&self, i: usize, out: &mut T);
}

/// `kernel.row(i, &mut out[i])` for every row `i`, split across threads as
/// [`rows`] is, each task's loop compiled for the CPU's instruction set.
pub(crate) fn kernel_rows<T: Send, K: RowKernel<T>>(out: &mut [T], kernel: &K) {
    kernel_rows_from(0, out, kernel);
}

fn kernel_rows_from<T: Send, K: RowKernel<T>>(first: usize, out: &mut [T], kernel: &K) {
    if sequential(out.len()) {
        pulp::Arch::new().dispatch(KernelLoop { first, out, kernel });
    } else {
        let mid = out.len() / 2;
        let (lo, hi) = out.split_at_mut(mid);
        join(
            || kernel_rows_from(first, lo, kernel),
            || kernel_rows_from(first + mid, hi, kernel),
        );
    }
}

/// The loop of one task of [`kernel_rows`] as a [`pulp::WithSimd`]
/// operation (dispatched without `unsafe` here).
struct KernelLoop<'a, T, K> {
    first: usize,
    out: &'a mut [T],
    kernel: &'a K,
}

impl<T, K: RowKernel<T>> pulp::WithSimd for KernelLoop<'_, T, K> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        for (i, y) in self.out.iter_mut().enumerate() {
            self.kernel.row(self.first + i, y);
        }
    }
}

/// One row of a compressed-row kernel run by [`kernel_row_slices_with`]:
/// row `i`'s slice `row` with the task's scratch `w` (as in
/// [`row_slices_with`]: a row's result must not depend on what an earlier
/// row left in `w`). `row` is to be marked `#[inline(always)]`, as
/// [`RowKernel::row`].
pub(crate) trait RowSliceKernel<T, W>: Sync {
    /// Row `i`'s slice `row`.
    fn row(&self, i: usize, row: &mut [T], w: &mut W);
}

/// [`row_slices_with`] for a [`RowSliceKernel`], each task's loop compiled
/// for the CPU's instruction set (as [`kernel_rows`]).
pub(crate) fn kernel_row_slices_with<T: Send, W, I, K>(
    row_ptr: &[usize],
    data: &mut [T],
    init: &I,
    kernel: &K,
) where
    I: Fn() -> W + Sync,
    K: RowSliceKernel<T, W>,
{
    kernel_slices_from(row_ptr, 0, row_ptr.len() - 1, data, init, kernel);
}

fn kernel_slices_from<T: Send, W, I, K>(
    row_ptr: &[usize],
    start: usize,
    rows: usize,
    data: &mut [T],
    init: &I,
    kernel: &K,
) where
    I: Fn() -> W + Sync,
    K: RowSliceKernel<T, W>,
{
    if sequential(rows) {
        let mut w = init();
        pulp::Arch::new().dispatch(SliceLoop {
            row_ptr,
            start,
            rows,
            data,
            w: &mut w,
            kernel,
        });
    } else {
        let mid = rows / 2;
        let (lo, hi) = data.split_at_mut(row_ptr[start + mid] - row_ptr[start]);
        join(
            || kernel_slices_from(row_ptr, start, mid, lo, init, kernel),
            || kernel_slices_from(row_ptr, start + mid, rows - mid, hi, init, kernel),
        );
    }
}

/// The loop of one task of [`kernel_row_slices_with`].
struct SliceLoop<'a, T, W, K> {
    row_ptr: &'a [usize],
    start: usize,
    rows: usize,
    data: &'a mut [T],
    w: &'a mut W,
    kernel: &'a K,
}

impl<T, W, K: RowSliceKernel<T, W>> pulp::WithSimd for SliceLoop<'_, T, W, K> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let base = self.row_ptr[self.start];
        for i in self.start..self.start + self.rows {
            let row = &mut self.data[self.row_ptr[i] - base..self.row_ptr[i + 1] - base];
            self.kernel.row(i, row, self.w);
        }
    }
}

/// `f(i, &mut data[row_ptr[i]..row_ptr[i + 1]])` for every row `i` of a
/// compressed-row array (`data.len() == row_ptr[n]`), split across threads.
pub(crate) fn row_slices<T: Send, F: Fn(usize, &mut [T]) + Sync>(
    row_ptr: &[usize],
    data: &mut [T],
    f: &F,
) {
    row_slices_with(row_ptr, data, &|| (), &|i, row, _: &mut ()| f(i, row));
}

/// [`row_slices`] with scratch: `f(i, row, &mut w)` with `w = init()` made
/// once per task (a run of up to [`ROWS_PER_TASK`] rows on one thread), not
/// once per row. `f` must not let a row's result depend on what an earlier
/// row left in `w` (the split into tasks depends on the thread count).
pub(crate) fn row_slices_with<T: Send, W, I, F>(row_ptr: &[usize], data: &mut [T], init: &I, f: &F)
where
    I: Fn() -> W + Sync,
    F: Fn(usize, &mut [T], &mut W) + Sync,
{
    // Zero-sized per-row outputs: these vectors allocate nothing.
    let n = row_ptr.len() - 1;
    let (mut u, mut v) = (vec![(); n], vec![(); n]);
    rows_and_slices_with(
        row_ptr,
        0,
        &mut u,
        &mut v,
        data,
        init,
        &|i, _, _, row, w| f(i, row, w),
    );
}

/// [`row_slices_with`] with two per-row outputs besides the row's slice:
/// `f(i, &mut x[i], &mut y[i], row, &mut w)` for the rows `i` from `start`
/// (`x` and `y` hold one entry per row, `data` the rows' slices).
#[allow(clippy::too_many_arguments)]
pub(crate) fn rows_and_slices_with<X: Send, Y: Send, T: Send, W, I, F>(
    row_ptr: &[usize],
    start: usize,
    x: &mut [X],
    y: &mut [Y],
    data: &mut [T],
    init: &I,
    f: &F,
) where
    I: Fn() -> W + Sync,
    F: Fn(usize, &mut X, &mut Y, &mut [T], &mut W) + Sync,
{
    let rows = x.len();
    if sequential(rows) {
        let base = row_ptr[start];
        let mut w = init();
        for (k, (xi, yi)) in x.iter_mut().zip(y.iter_mut()).enumerate() {
            let i = start + k;
            f(
                i,
                xi,
                yi,
                &mut data[row_ptr[i] - base..row_ptr[i + 1] - base],
                &mut w,
            );
        }
    } else {
        let mid = rows / 2;
        let (x_lo, x_hi) = x.split_at_mut(mid);
        let (y_lo, y_hi) = y.split_at_mut(mid);
        let (lo, hi) = data.split_at_mut(row_ptr[start + mid] - row_ptr[start]);
        join(
            || rows_and_slices_with(row_ptr, start, x_lo, y_lo, lo, init, f),
            || rows_and_slices_with(row_ptr, start + mid, x_hi, y_hi, hi, init, f),
        );
    }
}
