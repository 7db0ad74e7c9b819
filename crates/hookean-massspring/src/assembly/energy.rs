//! The springs' elastic energy `sum_s k_s (l_s - l0_s)^2 / 2` in one pass
//! over the assembly's spring table, by chunks of [`CHUNK`] springs in the
//! sweep's structure-of-arrays form ([`ChunkGeometry`]), so that the square
//! roots vectorise as in the force sweep. The energy guard of
//! `hookean::Simulation` evaluates it after every step; written as a loop of
//! `sqrt`s over the model's spring list it took 22% of the samples of the
//! explicit 64 x 64 drape's steps, 13% in this form (docs/PERFORMANCE.md,
//! "The energy check after every step").

use super::HotSpring;
use super::sweep::{CHUNK, ChunkGeometry};
use crate::model::MassSpringModel;

/// [`spring_energy`](MassSpringModel::spring_energy) as a
/// [`pulp::WithSimd`] operation, compiled for the instruction set the CPU
/// offers (checked at run time by `pulp::Arch::dispatch`).
struct SpringEnergy<'a> {
    hot: &'a [HotSpring],
    x: &'a [[f64; 3]],
}

impl pulp::WithSimd for SpringEnergy<'_> {
    type Output = Option<f64>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Option<f64> {
        let mut geo = ChunkGeometry::new();
        // Per lane a partial sum and the shortest length, combined in lane
        // order at the end: no dependency runs from one spring to the next
        // (a single running minimum made this loop latency-bound), and the
        // sum's order is fixed, so its bits do not depend on the machine.
        let mut sum = [0.0f64; CHUNK];
        let mut shortest = [f64::INFINITY; CHUNK];
        let mut chunks = self.hot.chunks_exact(CHUNK);
        for chunk in &mut chunks {
            geo.compute_lengths(self.x, chunk);
            for k in 0..CHUNK {
                let l = geo.l[k];
                shortest[k] = shortest[k].min(l);
                let stretch = l - chunk[k].rest_length;
                sum[k] += 0.5 * chunk[k].stiffness * stretch * stretch;
            }
        }
        let tail = chunks.remainder();
        geo.compute_lengths(self.x, tail);
        for (k, h) in tail.iter().enumerate() {
            let l = geo.l[k];
            shortest[k] = shortest[k].min(l);
            let stretch = l - h.rest_length;
            sum[k] += 0.5 * h.stiffness * stretch * stretch;
        }
        let shortest = shortest.iter().copied().fold(f64::INFINITY, f64::min);
        (shortest > 0.0).then(|| sum.iter().sum())
    }
}

impl MassSpringModel {
    /// The springs' elastic energy `sum_s k_s (l_s - l0_s)^2 / 2` at `x`
    /// (the potential of the spring force in [`assembly`](super)), or `None`
    /// when a spring has length 0.
    /// No allocation.
    ///
    /// # Panics
    /// If `x.len() != 3 n`.
    pub(crate) fn spring_energy(&self, x: &[f64]) -> Option<f64> {
        assert_eq!(x.len(), 3 * self.n_particles(), "x must have length 3 n");
        pulp::Arch::new().dispatch(SpringEnergy {
            hot: &self.plan.hot,
            x: x.as_chunks::<3>().0,
        })
    }
}
