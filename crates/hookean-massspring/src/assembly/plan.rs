//! [`AssemblyPlan`]: the assembly's layout, built once per model: each
//! spring's slots in the block pattern, the rows' spring ranges and the
//! rayon parts with their halos.
use std::sync::Arc;

use hookean_sparse::{BlockPattern, Slot, SymBlockMatrix};

use crate::error::MassSpringError;
use crate::model::{DampingInDfdx, Spring};

use super::*;

/// Which parts a private assembly call computes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AssemblyMode {
    pub(crate) clamp: bool,
    pub(crate) damping_in_dfdx: DampingInDfdx,
}
/// The cached storage slots of one spring's three blocks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SpringSlots {
    pub(crate) ii: Slot,
    pub(crate) jj: Slot,
    pub(crate) ij: Slot,
}

/// A spring prepared for the hot loops: springs are kept in the storage
/// order of their upper block, so that assembly writes the off-diagonal
/// blocks sequentially. Oriented `i < j` (the force law and the symmetric
/// Jacobian blocks do not depend on the orientation); 40 bytes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HotSpring {
    pub(crate) i: u32,
    pub(crate) j: u32,
    /// Index of the stored upper block `(min, max)` in the value array.
    pub(crate) upper: u32,
    pub(crate) rest_length: f64,
    pub(crate) stiffness: f64,
    pub(crate) damping: f64,
    /// Whether this spring is the first (in storage order) of its block:
    /// it assigns the block, later springs of the same pair add to it.
    pub(crate) first: bool,
}

/// Per-particle diagonal accumulators of assembly (the 6 unique entries of
/// the symmetric diagonal block of `df/dx`, then of `df/dv`), kept contiguous so that the
/// scatter to the second endpoint of a spring hits a compact array. All
/// zeros between calls (each row zeroes its entry when it writes its
/// diagonal blocks). Behind a mutex because the `SecondOrderProblem` methods
/// take `&self`; a concurrent second caller (or any caller after a panic
/// poisoned the mutex) falls back to a temporary zeroed buffer.
/// The second vector holds the halos of the threaded sweep (all zeros
/// between calls too), grown on the first threaded call.
#[derive(Debug, Default)]
pub(crate) struct DiagScratch(pub(crate) std::sync::Mutex<(Vec<Acc>, Vec<Halo>)>);

impl Clone for DiagScratch {
    fn clone(&self) -> Self {
        let n = self.0.lock().map(|v| v.0.len()).unwrap_or(0);
        DiagScratch(std::sync::Mutex::new((vec![[0.0; 12]; n], Vec::new())))
    }
}

/// Where the assembly sweep writes each spring's blocks: the Jacobian
/// pattern of a spring set and the positions of its blocks in the value
/// array, built once from `hookean-sparse`'s public slot API (the storage
/// layout is that crate's business), plus the per-row fast-path flags that
/// the step's constraints switch.
#[derive(Debug, Clone)]
pub(crate) struct AssemblyPlan {
    pub(crate) pattern: Arc<BlockPattern>,
    pub(crate) slots: Vec<SpringSlots>,
    pub(crate) diag_slots: Vec<Slot>,
    /// The springs in storage order of their upper block.
    pub(crate) hot: Vec<HotSpring>,
    /// `hot[hot_row_ptr[r]..hot_row_ptr[r + 1]]` are the springs whose
    /// upper block lies in block row `r = min(i, j)`.
    pub(crate) hot_row_ptr: Vec<usize>,
    /// Value index of each diagonal block.
    pub(crate) diag_index: Vec<usize>,
    /// Whether block row `r` takes the fast assembly path: no spring of the
    /// row, nor its diagonal, touches a constrained particle (kept up to
    /// date through [`mark_rows_of`](Self::mark_rows_of)).
    pub(crate) row_fast: Vec<bool>,
    /// `touch_rows[touch_ptr[p]..touch_ptr[p + 1]]` are the block rows whose
    /// springs or diagonal touch particle `p` (`p` itself and the rows
    /// `min(i, j)` of its springs).
    pub(crate) touch_ptr: Vec<usize>,
    /// See `touch_ptr`.
    pub(crate) touch_rows: Vec<u32>,
    /// `max (j - i)` over the stored blocks: how far past its rows a part
    /// of the threaded sweep scatters.
    pub(crate) bandwidth: usize,
    pub(crate) diag_acc: DiagScratch,
}

impl AssemblyPlan {
    /// The plan of `springs` (already checked) on `n` particles.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] when a storage position does not
    /// fit the 32-bit tables; the pattern's errors.
    pub(crate) fn new(n: usize, springs: &[Spring]) -> Result<Self, MassSpringError> {
        let pattern = Arc::new(BlockPattern::new(n, springs.iter().map(|s| (s.i, s.j)))?);
        let probe = SymBlockMatrix::new(pattern.clone());
        let slots = springs
            .iter()
            .map(|s| {
                Ok(SpringSlots {
                    ii: probe.slot(s.i, s.i)?,
                    jj: probe.slot(s.j, s.j)?,
                    ij: probe.slot(s.i, s.j)?,
                })
            })
            .collect::<Result<Vec<_>, hookean_sparse::SparseError>>()?;
        let diag_slots = (0..n)
            .map(|p| probe.slot(p, p))
            .collect::<Result<Vec<_>, _>>()?;
        // The pattern's column indices are u32, so particle indices fit;
        // storage positions (from the pattern's slots) are checked.
        let to_u32 = |k: usize| {
            u32::try_from(k).map_err(|_| MassSpringError::InvalidParameter {
                name: "springs",
                message: format!("index {k} does not fit the 32-bit assembly tables"),
            })
        };
        let mut hot: Vec<HotSpring> = Vec::with_capacity(springs.len());
        for s in springs {
            let (r, c) = (s.i.min(s.j), s.i.max(s.j));
            let upper = pattern
                .find(r, c)
                .ok_or(hookean_sparse::SparseError::NotInPattern { row: r, col: c })?;
            hot.push(HotSpring {
                i: to_u32(r)?,
                j: to_u32(c)?,
                rest_length: s.rest_length,
                stiffness: s.stiffness,
                damping: s.damping,
                upper: to_u32(upper.index())?,
                first: false,
            });
        }
        hot.sort_by_key(|h| h.upper);
        for k in 0..hot.len() {
            hot[k].first = k == 0 || hot[k - 1].upper != hot[k].upper;
        }
        let diag_index = diag_slots.iter().map(Slot::index).collect();
        let bandwidth = pattern.bandwidth();
        let mut hot_row_ptr = vec![0usize; n + 1];
        for h in &hot {
            hot_row_ptr[h.i as usize + 1] += 1;
        }
        for r in 0..n {
            hot_row_ptr[r + 1] += hot_row_ptr[r];
        }
        let mut touch_ptr = vec![1usize; n + 1];
        touch_ptr[0] = 0;
        for h in &hot {
            touch_ptr[h.j as usize + 1] += 1;
        }
        for p in 0..n {
            touch_ptr[p + 1] += touch_ptr[p];
        }
        let mut touch_rows = vec![0u32; touch_ptr[n]];
        let mut fill = touch_ptr.clone();
        for p in 0..n {
            touch_rows[fill[p]] = to_u32(p)?;
            fill[p] += 1;
        }
        for h in &hot {
            let hi = h.j as usize;
            touch_rows[fill[hi]] = h.i;
            fill[hi] += 1;
        }
        Ok(Self {
            pattern,
            slots,
            diag_slots,
            hot,
            hot_row_ptr,
            diag_index,
            row_fast: vec![true; n],
            touch_ptr,
            touch_rows,
            bandwidth,
            diag_acc: DiagScratch(std::sync::Mutex::new((vec![[0.0; 12]; n], Vec::new()))),
        })
    }

    /// Sets the fast-path flag of every block row that touches particle `p`.
    pub(crate) fn mark_rows_of(&mut self, p: usize, fast: bool) {
        for &r in &self.touch_rows[self.touch_ptr[p]..self.touch_ptr[p + 1]] {
            self.row_fast[r as usize] = fast;
        }
    }
}
