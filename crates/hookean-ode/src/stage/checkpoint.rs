//! The checkpoint of the reduced velocity form ([`SecondSys`]), and of a
//! Newton solver with PCG ([`save_newton`], [`NewtonRecord`]) that it,
//! eq. 50's path (`linearized.rs`) and the variable-order BDF's corrector
//! (`bdf/second_order.rs`) each hold.
//!
//! A Newton solver carries to its next call its contraction rate, a kept
//! Jacobian (the simplified variants) with the linear solver set up on it,
//! and the multigrid's hierarchy. The kept matrix is saved by its holder
//! (its values, or what rebuilds it bit for bit: eq. 50's `M - gh D -
//! gh^2 K` from the model's constant `K`, `D` and `gh`); the multigrid is
//! rebuilt from the matrix of its last full set-up
//! ([`Amg::built_from`](hookean_sparse::Amg::built_from)) and then, if its
//! last set-up was a refill, refilled with the kept matrix (with `reuse =
//! "keep"`, with the matrix of its last refill, which it keeps itself, and
//! its count of kept set-ups), which is the hierarchy the saved solver
//! holds ([`Amg::restore`](hookean_sparse::Amg::restore)).

use std::sync::Arc;

use hookean_nonlinear::{LinearSolver, Newton, PcgSolver};
use hookean_problem::SecondOrderProblem;
use hookean_sparse::{AnyPreconditioner, BlockPattern, SymBlockMatrix};

use super::second_order::SecondSys;
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::snapshot::{StateRecord, not_covered};

fn flag(b: bool) -> f64 {
    f64::from(u8::from(b))
}

fn misfit(reason: String) -> OdeError {
    OdeError::Checkpoint { reason }
}

/// The values of `a`, block by block (9 numbers each, row by row).
pub(crate) fn matrix_values(a: &SymBlockMatrix) -> Vec<f64> {
    a.values().iter().flatten().flatten().copied().collect()
}

/// Writes [`matrix_values`] back into `a` (`v` has 9 numbers per stored
/// block: checked by [`matrix_entry`]).
pub(crate) fn set_matrix_values(a: &mut SymBlockMatrix, v: &[f64]) {
    for (b, w) in a.values_mut().iter_mut().zip(v.chunks_exact(9)) {
        for (row, x) in b.iter_mut().zip(w.chunks_exact(3)) {
            row.copy_from_slice(x);
        }
    }
}

/// The record's matrix `name` on `pattern`: empty (none) or 9 numbers
/// per stored block.
pub(crate) fn matrix_entry<'a>(
    r: &'a StateRecord,
    name: &str,
    pattern: &BlockPattern,
) -> Result<&'a [f64], OdeError> {
    let values = r.get(name)?;
    let blocks = 9 * pattern.col_idx().len();
    if !values.is_empty() && values.len() != blocks {
        return Err(misfit(format!(
            "entry `{name}` has {} numbers, this run's matrix {blocks}",
            values.len()
        )));
    }
    Ok(values)
}

/// [`OdeError::NoCheckpoint`] for a multigrid that carries eigenvector
/// estimates from one refill to the next
/// ([`Amg::carries_eigenvector_estimates`](hookean_sparse::Amg::carries_eigenvector_estimates)).
fn check_multigrid(linear: &PcgSolver<AnyPreconditioner>) -> Result<(), OdeError> {
    if let AnyPreconditioner::Amg(amg) = linear.preconditioner()
        && amg.carries_eigenvector_estimates()
    {
        return Err(not_covered(
            "a multigrid that carries eigenvector estimates from refill to refill \
             (solver.amg.refill_power_iterations > 0 with solver.amg.power_iterations > 0)",
        ));
    }
    Ok(())
}

/// Puts under `prefix` what a Newton solver with PCG carries to its next
/// call: `{prefix}.newton` = its carried rate and whether it keeps a
/// Jacobian ([`Newton::carried_state`]), and whether that is the system's
/// approximation; for a multigrid, `{prefix}.amg.built_from` (the matrix
/// of its last full set-up, empty for none), `{prefix}.amg.refilled`
/// (whether a refill followed it), and with `reuse = "keep"`
/// `{prefix}.amg.refilled_from` (the matrix of that refill, which the kept
/// set-ups go on using; empty otherwise) and `{prefix}.amg.kept_in_a_row`.
/// The kept Jacobian's matrix is the caller's to save.
///
/// # Errors
/// [`OdeError::NoCheckpoint`] for a multigrid that carries eigenvector
/// estimates.
pub(crate) fn save_newton<J>(
    newton: &Newton<J, PcgSolver<AnyPreconditioner>>,
    prefix: &str,
    r: &mut StateRecord,
) -> Result<(), OdeError>
where
    PcgSolver<AnyPreconditioner>: LinearSolver<J>,
{
    check_multigrid(newton.linear_solver())?;
    let [rate, has_known, known, kept] = newton.carried_state();
    r.put(
        &format!("{prefix}.newton"),
        &[
            rate,
            has_known,
            known,
            kept,
            flag(newton.jacobian_is_approximated()),
        ],
    );
    if let AnyPreconditioner::Amg(amg) = newton.linear_solver().preconditioner() {
        let built = amg.built_from().map(matrix_values).unwrap_or_default();
        r.put(&format!("{prefix}.amg.built_from"), &built);
        r.put_scalar(
            &format!("{prefix}.amg.refilled"),
            flag(amg.last_setup_refilled()),
        );
        let refilled = amg.refilled_from().map(matrix_values).unwrap_or_default();
        r.put(&format!("{prefix}.amg.refilled_from"), &refilled);
        r.put_scalar(
            &format!("{prefix}.amg.kept_in_a_row"),
            amg.kept_in_a_row() as f64,
        );
    }
    Ok(())
}

/// What [`save_newton`] put, read and checked before anything changes.
pub(crate) struct NewtonRecord {
    carried: [f64; 4],
    approximated: bool,
    /// The multigrid's build matrix (none: no multigrid, or none built).
    built_from: Option<SymBlockMatrix>,
    refilled: bool,
    /// The matrix of its last refill, if it keeps one (`reuse = "keep"`).
    refilled_from: Option<SymBlockMatrix>,
    kept_in_a_row: usize,
}

impl NewtonRecord {
    /// Reads `prefix`'s entries for a solver whose matrices have
    /// `pattern` and whose linear solver is `linear`.
    ///
    /// # Errors
    /// As [`save_newton`]; [`OdeError::Checkpoint`] for a missing or
    /// malformed entry.
    pub(crate) fn read(
        r: &StateRecord,
        prefix: &str,
        pattern: &Arc<BlockPattern>,
        linear: &PcgSolver<AnyPreconditioner>,
    ) -> Result<Self, OdeError> {
        check_multigrid(linear)?;
        let name = format!("{prefix}.newton");
        let c = r.get_len(&name, 5)?;
        if [c[1], c[3], c[4]].iter().any(|&f| f != 0.0 && f != 1.0) {
            return Err(misfit(format!(
                "entry `{name}` has a flag that is not 0 or 1"
            )));
        }
        let matrix = |name: &str| -> Result<Option<SymBlockMatrix>, OdeError> {
            let values = matrix_entry(r, &format!("{prefix}.amg.{name}"), pattern)?;
            Ok((!values.is_empty()).then(|| {
                let mut a = SymBlockMatrix::new(pattern.clone());
                set_matrix_values(&mut a, values);
                a
            }))
        };
        let (built_from, refilled, refilled_from, kept_in_a_row) = match linear.preconditioner() {
            AnyPreconditioner::Amg(_) => (
                matrix("built_from")?,
                r.flag(&format!("{prefix}.amg.refilled"))?,
                matrix("refilled_from")?,
                r.count(&format!("{prefix}.amg.kept_in_a_row"))?,
            ),
            _ => (None, false, None, 0),
        };
        Ok(Self {
            carried: [c[0], c[1], c[2], c[3]],
            approximated: c[4] == 1.0,
            built_from,
            refilled,
            refilled_from,
            kept_in_a_row,
        })
    }

    /// Whether the saved solver kept a Jacobian for its next call.
    pub(crate) fn kept(&self) -> bool {
        self.carried[3] == 1.0
    }

    /// Restores the record into `newton` (of a system of `n` unknowns):
    /// the multigrid rebuilt from its build matrix (and refilled from its
    /// own copy with `reuse = "keep"`: [`Amg::restore`](hookean_sparse::Amg::restore)), the carried
    /// rate, and with a kept Jacobian the matrix `fill` writes, the linear
    /// solver set up on it unless the restored multigrid is that set-up
    /// already (its last set-up was the full one, or the refill it kept).
    ///
    /// # Errors
    /// The multigrid's or the linear solver's set-up errors.
    pub(crate) fn restore<J>(
        self,
        newton: &mut Newton<J, PcgSolver<AnyPreconditioner>>,
        n: usize,
        fill: impl FnOnce(&mut J),
    ) -> Result<(), OdeError>
    where
        PcgSolver<AnyPreconditioner>: LinearSolver<J>,
    {
        let kept = self.kept();
        let restored = self.built_from.is_some();
        if let Some(a) = &self.built_from
            && let AnyPreconditioner::Amg(m) = newton.linear_solver_mut().preconditioner_mut()
        {
            m.restore(a, self.refilled_from.as_ref(), self.kept_in_a_row)?;
        }
        newton.set_carried_state(self.carried);
        if kept {
            let setup = !restored || (self.refilled && self.refilled_from.is_none());
            newton.keep_jacobian(n, self.approximated, setup, fill)?;
        }
        Ok(())
    }
}

impl<P: SecondOrderProblem> SecondSys<P> {
    /// Everything the next stage reuses: the Newton solver's carried state
    /// and kept Jacobian (simplified variants: `sys.newton.kept`, its
    /// values), the `gh` and material revision it belongs to, the warm
    /// start, eq. 50's path (`linearized.rs`) and the IMEX scheme's factor
    /// (what rebuilds it: [`Imex::carried`](crate::imex::Imex::carried)).
    /// `df/dx`, `df/dv`, the force and the positions are written before
    /// they are read.
    pub(super) fn save_checkpoint(&self, r: &mut StateRecord) -> Result<(), OdeError> {
        save_newton(&self.newton, "sys", r)?;
        let kept = if self.newton.jacobian_is_kept() {
            matrix_values(self.newton.jacobian())
        } else {
            Vec::new()
        };
        r.put("sys.newton.kept", &kept);
        r.put_scalar("sys.last_gh", self.last_gh);
        r.put_scalar("sys.revision", self.revision as f64);
        r.put("sys.last_delta", &self.last_delta);
        r.put_scalar("sys.last_delta_gh", self.last_delta_gh);
        self.save_linearized(r)?;
        match &self.imex {
            Some(imex) => r.put("sys.imex", &imex.carried()),
            None => r.put("sys.imex", &[]),
        }
        Ok(())
    }

    /// Restores [`save_checkpoint`](Self::save_checkpoint); every entry is
    /// read and checked (and what is rebuilt, built) before `self` changes.
    pub(super) fn restore_checkpoint(
        &mut self,
        r: &StateRecord,
        opts: &SolverOptions,
    ) -> Result<(), OdeError> {
        let pattern = self.newton.jacobian().pattern().clone();
        let newton = NewtonRecord::read(r, "sys", &pattern, self.newton.linear_solver())?;
        let kept = matrix_entry(r, "sys.newton.kept", &pattern)?;
        if newton.kept() == kept.is_empty() {
            return Err(misfit(
                "entry `sys.newton.kept` does not match the kept-Jacobian flag of `sys.newton`"
                    .into(),
            ));
        }
        let last_delta = r.get_len("sys.last_delta", self.n)?;
        let (last_gh, last_delta_gh) = (r.scalar("sys.last_gh")?, r.scalar("sys.last_delta_gh")?);
        let revision = r.count("sys.revision")? as u64;
        let linearized = self.restored_linearized(r, opts)?;
        let imex = match r.get("sys.imex")? {
            [] => None,
            carried => Some(Box::new(crate::imex::Imex::restored(
                &self.problem,
                carried,
            )?)),
        };
        newton.restore(&mut self.newton, self.n, |a| set_matrix_values(a, kept))?;
        self.last_gh = last_gh;
        self.last_delta_gh = last_delta_gh;
        self.revision = revision;
        self.last_delta.copy_from_slice(last_delta);
        self.linearized = linearized;
        self.imex = imex;
        Ok(())
    }
}
