//! The hierarchy behind [`Amg`](super::Amg) for any supported pair of
//! block sizes (`B` unknowns per finest node, `K` near-nullspace vectors,
//! so `K` unknowns per coarse node) and storage precision: one enum, so the
//! kernels stay compiled for their block sizes and the choice is made once
//! per call of the preconditioner, not in its loops.

use super::bsr::{Blk, Bsr};
use super::hierarchy::Hierarchy;
use super::{AmgLevelStats, AmgOptions, AmgPrecision, Source, fill};
use crate::error::SparseError;

/// `$body` with the constants `$b` (unknowns per finest node) and `$k`
/// (near-nullspace vectors) set to the runtime values `$nb, $nk` when the
/// pair is supported: `(1, 1)` (scalar), `(2, 2)`, `(2, 3)` (2D rigid-body
/// modes), `(3, 3)` (translations), `(3, 6)` (3D rigid-body modes); else
/// `$other`.
macro_rules! with_block_sizes {
    ($nb:expr, $nk:expr, $b:ident, $k:ident => $body:expr, _ => $other:expr) => {
        match ($nb, $nk) {
            (1, 1) => {
                const $b: usize = 1;
                const $k: usize = 1;
                $body
            }
            (2, 2) => {
                const $b: usize = 2;
                const $k: usize = 2;
                $body
            }
            (2, 3) => {
                const $b: usize = 2;
                const $k: usize = 3;
                $body
            }
            (3, 3) => {
                const $b: usize = 3;
                const $k: usize = 3;
                $body
            }
            (3, 6) => {
                const $b: usize = 3;
                const $k: usize = 6;
                $body
            }
            _ => $other,
        }
    };
}
pub(super) use with_block_sizes;

/// The pairs (unknowns per node, near-nullspace vectors) of
/// [`with_block_sizes`], for error messages.
pub(super) const SUPPORTED: &str =
    "1 vector on nodes of 1 unknown, 2 or 3 on nodes of 2, 3 or 6 on nodes of 3";

/// A hierarchy of one supported pair of block sizes, in either precision
/// (boxed: one pointer in [`Amg`](super::Amg), whatever the variant).
#[derive(Debug, Clone)]
pub(super) enum Levels {
    S11(Box<Hierarchy<1, 1, f32>>),
    D11(Box<Hierarchy<1, 1, f64>>),
    S22(Box<Hierarchy<2, 2, f32>>),
    D22(Box<Hierarchy<2, 2, f64>>),
    S23(Box<Hierarchy<2, 3, f32>>),
    D23(Box<Hierarchy<2, 3, f64>>),
    S33(Box<Hierarchy<3, 3, f32>>),
    D33(Box<Hierarchy<3, 3, f64>>),
    S36(Box<Hierarchy<3, 6, f32>>),
    D36(Box<Hierarchy<3, 6, f64>>),
}

macro_rules! from_hierarchy {
    ($($variant:ident: $b:literal, $k:literal, $s:ty;)*) => {
        $(impl From<Hierarchy<$b, $k, $s>> for Levels {
            fn from(h: Hierarchy<$b, $k, $s>) -> Self {
                Levels::$variant(Box::new(h))
            }
        })*
    };
}

from_hierarchy! {
    S11: 1, 1, f32; D11: 1, 1, f64; S22: 2, 2, f32; D22: 2, 2, f64; S23: 2, 3, f32;
    D23: 2, 3, f64; S33: 3, 3, f32; D33: 3, 3, f64; S36: 3, 6, f32; D36: 3, 6, f64;
}

/// `$body` with `$h` bound to the hierarchy of `$levels`, whatever its
/// block sizes and precision.
macro_rules! with_levels {
    ($levels:expr, $h:ident => $body:expr) => {
        match $levels {
            Levels::S11($h) => $body,
            Levels::D11($h) => $body,
            Levels::S22($h) => $body,
            Levels::D22($h) => $body,
            Levels::S23($h) => $body,
            Levels::D23($h) => $body,
            Levels::S33($h) => $body,
            Levels::D33($h) => $body,
            Levels::S36($h) => $body,
            Levels::D36($h) => $body,
        }
    };
}

impl Levels {
    /// The full set-up from the finest pattern `fine` (values zero), filled
    /// from `source` in the storage precision of `options`, with the
    /// near-nullspace `nullspace` (one `B x K` block per node).
    pub fn new<const B: usize, const K: usize>(
        fine: &Bsr<B>,
        source: &Source<'_>,
        nullspace: Vec<Blk<B, K>>,
        options: &AmgOptions,
    ) -> Result<Self, SparseError>
    where
        Hierarchy<B, K, f32>: Into<Self>,
        Hierarchy<B, K, f64>: Into<Self>,
    {
        Ok(match options.precision {
            AmgPrecision::Single => {
                let mut a = fine.pattern_as::<f32>();
                fill(&mut a, source)?;
                Hierarchy::<B, K, f32>::new(a, nullspace, options)?.into()
            }
            AmgPrecision::Double => {
                let mut a = fine.pattern_as::<f64>();
                fill(&mut a, source)?;
                Hierarchy::<B, K, f64>::new(a, nullspace, options)?.into()
            }
        })
    }

    /// Refills the finest level from `source` and recomputes every number.
    pub fn refill(&mut self, source: &Source<'_>) -> Result<(), SparseError> {
        with_levels!(self, h => {
            fill(h.finest_mut(), source)?;
            h.compute()
        })
    }

    pub fn dim(&self) -> usize {
        with_levels!(self, h => h.dim())
    }

    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        with_levels!(self, h => h.apply(r, z))
    }

    pub fn update_and_apply(
        &self,
        alpha: f64,
        q: &[f64],
        r: &mut [f64],
        z: &mut [f64],
    ) -> (f64, f64) {
        with_levels!(self, h => h.update_and_apply(alpha, q, r, z))
    }

    pub fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        with_levels!(self, h => h.apply_dot(r, z))
    }

    pub fn level_stats(&self) -> Vec<AmgLevelStats> {
        with_levels!(self, h => h.level_stats().collect())
    }

    /// Copies the smoothers' and prolongators' weights into `stats` (no allocation).
    pub fn update_weights(&self, stats: &mut [AmgLevelStats]) {
        with_levels!(self, h => {
            for (s, l) in stats.iter_mut().zip(h.level_stats()) {
                s.smoother_weight = l.smoother_weight;
                s.prolongation_weight = l.prolongation_weight;
            }
        })
    }

    pub fn coarsest_direct(&self) -> bool {
        with_levels!(self, h => h.coarsest_direct())
    }

    /// Test access: every level's matrices, dense.
    #[cfg(test)]
    pub fn dense_levels(&self) -> Vec<super::hierarchy::DenseLevel> {
        with_levels!(self, h => h.dense_levels())
    }
}
