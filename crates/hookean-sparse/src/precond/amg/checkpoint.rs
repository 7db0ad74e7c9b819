//! What a checkpoint needs of a multigrid ([`Amg`]): the matrices its
//! hierarchy was built and last refilled from, the count of kept set-ups,
//! and [`Amg::restore`], which gives the hierarchy back from them bit for
//! bit.

use std::sync::Arc;
use std::time::Instant;

use super::{Amg, AmgReuse, Inner, Source};
use crate::SparseError;
use crate::matrix::SymBlockMatrix;

impl Amg {
    /// The matrix the current hierarchy was built from (its last full
    /// set-up from a [`SymBlockMatrix`]), when a refill reuses what was
    /// built from it: with [`AmgReuse::Refill`] and no
    /// [`refill_power_iterations`](super::AmgOptions::refill_power_iterations),
    /// the strength graph, aggregates, tentative prolongators and spectral
    /// estimates are functions of this matrix alone (the set-up is
    /// deterministic, whatever the thread count), and every other number is
    /// recomputed at each refill. So [`rebuild`](Amg::rebuild) from it,
    /// followed by the next refill, gives the preconditioner bit for bit:
    /// how a checkpointed run restores its multigrid without keeping the
    /// hierarchy itself. `None` before a set-up, from a CSR matrix, or with
    /// [`AmgReuse::Rebuild`] (nothing is reused).
    pub fn built_from(&self) -> Option<&SymBlockMatrix> {
        self.built_from.as_ref()
    }

    /// Whether the last `setup` that changed the hierarchy refilled it
    /// (`false`: it was a full set-up, from [`built_from`](Amg::built_from)
    /// itself). A checkpoint restores a hierarchy last set up with a
    /// matrix `A` by [`restore`](Amg::restore) from `built_from` and, if
    /// this is true, `A`.
    pub fn last_setup_refilled(&self) -> bool {
        self.last_refilled
    }

    /// With [`AmgReuse::Keep`] after a refill, the matrix of that refill,
    /// which the kept set-ups since go on using (copied at each refill;
    /// `None` otherwise).
    pub fn refilled_from(&self) -> Option<&SymBlockMatrix> {
        let keeps = matches!(self.options.reuse, AmgReuse::Keep { .. });
        if keeps && self.last_refilled {
            self.refilled_from.as_ref()
        } else {
            None
        }
    }

    /// The calls of `setup` that kept the hierarchy since its last set-up
    /// or refill ([`AmgReuse::Keep`]).
    pub fn kept_in_a_row(&self) -> usize {
        self.kept_in_a_row
    }

    /// Whether the hierarchy carries eigenvector estimates from one refill
    /// to the next ([`refill_power_iterations`](super::AmgOptions::refill_power_iterations)
    /// with [`power_iterations`](super::AmgOptions::power_iterations), and a
    /// policy that refills): then it is not a function of the matrices
    /// [`restore`](Amg::restore) takes.
    pub fn carries_eigenvector_estimates(&self) -> bool {
        self.options.reuse != AmgReuse::Rebuild
            && self.options.refill_power_iterations > 0
            && self.options.power_iterations > 0
    }

    /// The hierarchy of a checkpoint: a full set-up of `built_from` (see
    /// [`built_from`](Amg::built_from)), then a refill with `refilled`
    /// (whatever [`AmgReuse`] would plan), then `kept_in_a_row` (see
    /// [`kept_in_a_row`](Amg::kept_in_a_row)). Without eigenvector
    /// estimates ([`carries_eigenvector_estimates`](Amg::carries_eigenvector_estimates)) the strength graph,
    /// aggregates, tentative prolongators and spectral estimates are
    /// functions of `built_from` alone and a refill recomputes every other
    /// number from its matrix, so this is bit for bit the hierarchy of the
    /// saved run, and its next `setup` does what the saved run's would.
    ///
    /// # Errors
    /// As [`setup`](crate::precond::PreconditionerSetup::setup);
    /// [`SparseError::InvalidParameter`] for a `refilled` of another
    /// pattern than `built_from`.
    pub fn restore(
        &mut self,
        built_from: &SymBlockMatrix,
        refilled: Option<&SymBlockMatrix>,
        kept_in_a_row: usize,
    ) -> Result<(), SparseError> {
        self.rebuild(built_from)?;
        if let Some(a) = refilled {
            let start = Instant::now();
            let Inner::Block { source, map, h } = &mut self.inner else {
                return Err(SparseError::InvalidParameter {
                    name: "built_from",
                    message: "its set-up built no block hierarchy".into(),
                });
            };
            if !(Arc::ptr_eq(source, a.pattern()) || **source == **a.pattern()) {
                return Err(SparseError::InvalidParameter {
                    name: "refilled",
                    message: "its pattern is not that of the matrix the hierarchy was built from"
                        .into(),
                });
            }
            if let Err(e) = h.refill(&Source::Blocks(map, a)) {
                self.inner = Inner::Empty;
                return Err(e);
            }
            self.keep_refill_matrix(a);
            self.finish(start, true);
        }
        self.kept_in_a_row = kept_in_a_row;
        Ok(())
    }

    /// Keeps a copy of a refill's matrix with [`AmgReuse::Keep`] (the
    /// kept set-ups after it use its hierarchy): no allocation after the first.
    pub(super) fn keep_refill_matrix(&mut self, a: &SymBlockMatrix) {
        if !matches!(self.options.reuse, AmgReuse::Keep { .. }) {
            return;
        }
        match &mut self.refilled_from {
            Some(b) if Arc::ptr_eq(b.pattern(), a.pattern()) => {
                b.values_mut().copy_from_slice(a.values());
            }
            b => *b = Some(a.clone()),
        }
    }
}
