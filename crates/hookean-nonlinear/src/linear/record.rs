//! Recording the linear systems a [`PcgSolver`](super::PcgSolver) solves:
//! one hook on the solve path, off the hot loop ([`SolveRecorder`]).
//!
//! A solver without a recorder (the default) pays one branch per solve. With
//! one, every successful [`solve`](super::LinearSolver::solve) hands the
//! recorder what the solve was given and what it did, after it ran: enough
//! to replay it, the same PCG from the same start on the same constraints,
//! outside the run (`hookean export-system --every`, `hookean bench
//! --sequence`). A solve that fails with an error is not recorded.

use std::sync::{Arc, Mutex};

use hookean_sparse::Constraints;

use super::LinearSolveStats;

/// One linear solve `J x = rhs` of a [`PcgSolver`](super::PcgSolver), as a
/// [`SolveRecorder`] sees it after it ran.
pub struct RecordedSolve<'a> {
    /// A copy of `J` as CSR, on request (it allocates);
    /// [`matrix`](Self::matrix).
    pub(crate) matrix: &'a dyn Fn() -> Option<sprs::CsMat<f64>>,
    /// The right-hand side, as given (before the shift by prescribed values).
    pub rhs: &'a [f64],
    /// The starting guess (a warm start armed by
    /// [`arm_guess`](super::PcgSolver::arm_guess)); `None`: the solve started
    /// from zero.
    pub guess: Option<&'a [f64]>,
    /// The solution PCG returned.
    pub solution: &'a [f64],
    /// The constraints of filtered PCG, `None` when it was plain PCG.
    pub constraints: Option<&'a Constraints>,
    /// The relative tolerance the caller asked for.
    pub rtol: f64,
    /// The solver's iteration limit (`None`: `2 n`).
    pub max_iter: Option<usize>,
    /// Whether the preconditioner was set up since the last solve (from
    /// this matrix; `false`: a preconditioner of an earlier matrix).
    pub set_up: bool,
    /// What the solve did.
    pub stats: LinearSolveStats,
}

impl RecordedSolve<'_> {
    /// A copy of the matrix as CSR (both triangles), `None` for an operator
    /// that is not a stored matrix
    /// ([`LinearOperator::stored_matrix`](hookean_sparse::LinearOperator::stored_matrix)).
    pub fn matrix(&self) -> Option<sprs::CsMat<f64>> {
        (self.matrix)()
    }
}

/// Receives every solve of a [`PcgSolver`](super::PcgSolver) it is
/// installed in ([`PcgSolver::set_recorder`](super::PcgSolver::set_recorder)),
/// on the solving thread, after the solve. It keeps its own errors (a file
/// that cannot be written) for its owner to collect: a recording never
/// changes the run.
pub trait SolveRecorder: Send {
    /// One solve.
    fn record(&mut self, solve: &RecordedSolve<'_>);
}

/// A recorder shared by its owner and the solvers it is installed in (a
/// cloned [`PcgSolver`](super::PcgSolver) records into the same one).
pub type SharedRecorder = Arc<Mutex<dyn SolveRecorder>>;

/// The optional recorder of a solver: `Debug` without the recorder's
/// insides, cloned by sharing.
#[derive(Clone, Default)]
pub(crate) struct RecorderSlot(pub(crate) Option<SharedRecorder>);

impl std::fmt::Debug for RecorderSlot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "Some(recorder)"
        } else {
            "None"
        })
    }
}
