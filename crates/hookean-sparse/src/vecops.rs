//! Small dense vector kernels shared by the solvers.

/// `x . y`. Long vectors are summed by fixed-size leaves on the current
/// rayon pool's threads, the leaves added in a fixed tree order
/// (see [`par`](crate::par)): the same bits on every run.
#[inline]
pub fn dot(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len().min(y.len());
    crate::par::tree_sum(n, &|a, b| dot_serial(&x[a..b], &y[a..b]))
}

/// CG's residual update `r -= alpha q`, returning the new `r . r`
/// (summed serially in index order: the bits every fused variant keeps).
#[inline]
pub(crate) fn update_residual(alpha: f64, q: &[f64], r: &mut [f64]) -> f64 {
    let mut rr = 0.0;
    for (ri, qi) in r.iter_mut().zip(q) {
        *ri -= alpha * qi;
        rr += *ri * *ri;
    }
    rr
}

/// CG's direction update `x <- x + alpha p` (the previous step, old `p`),
/// then `p <- z + beta p`, element by element (threaded on long vectors:
/// the same bits for every split).
#[inline]
pub(crate) fn update_x_p(z: &[f64], beta: f64, alpha: f64, x: &mut [f64], p: &mut [f64]) {
    crate::par::for_each_chunk3(x, p, z, |xc, pc, zc| {
        for ((xi, pi), zi) in xc.iter_mut().zip(pc.iter_mut()).zip(zc) {
            *xi += alpha * *pi;
            *pi = zi + beta * *pi;
        }
    });
}

/// The serial kernel of [`dot`].
#[inline]
fn dot_serial(x: &[f64], y: &[f64]) -> f64 {
    // Four accumulators: a shorter dependency chain, and the same bits for
    // the same input on every run.
    let mut acc = [0.0; 4];
    let (xc, xr) = x.as_chunks::<4>();
    let (yc, yr) = y.as_chunks::<4>();
    for (a, b) in xc.iter().zip(yc) {
        acc[0] += a[0] * b[0];
        acc[1] += a[1] * b[1];
        acc[2] += a[2] * b[2];
        acc[3] += a[3] * b[3];
    }
    let mut tail = 0.0;
    for (a, b) in xr.iter().zip(yr) {
        tail += a * b;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// The Euclidean norm `|x|`.
#[inline]
pub fn norm2(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}

/// The largest absolute entry `max |x_i|`.
#[inline]
pub fn norm_inf(x: &[f64]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// `out = -x` (`out` at least as long as `x`). Indexed on slices cut to one
/// length: no bounds checks left and no zip chain, whose set-up costs more
/// than the negations on a few unknowns (the stiff solvers' correctors).
#[inline]
#[allow(clippy::needless_range_loop)]
pub fn negate_into(x: &[f64], out: &mut [f64]) {
    let n = x.len();
    let out = &mut out[..n];
    for i in 0..n {
        out[i] = -x[i];
    }
}
