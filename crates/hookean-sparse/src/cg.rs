//! Preconditioned conjugate gradients, plain and filtered (Baraff-Witkin,
//! the tutorial's Algorithm 4).

use crate::NonExhaustive;
use std::ops::ControlFlow;

use crate::constraints::Constraints;
use crate::error::{SparseError, check_finite, check_len};
use crate::lanczos::{ConditionEstimate, LANCZOS_CAPACITY};
use crate::operator::LinearOperator;
use crate::precond::Preconditioner;
use crate::vecops::{norm2, update_residual};

/// Where CG starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InitialGuess {
    /// Start from `x = 0` (whatever `x` holds is overwritten).
    #[default]
    Zero,
    /// Start from the `x` passed in: a warm start, e.g. the previous step's solution.
    Given,
}

/// Parameters of [`pcg`] and [`filtered_pcg`].
#[derive(Debug, Clone, PartialEq)]
pub struct CgParams {
    /// Stop when `|r| <= rtol * |b|` (for filtered CG, `|P b|`). Default `1e-8`.
    pub rtol: f64,
    /// ... or when `|r| <= atol`. Default `0`.
    pub atol: f64,
    /// Iteration limit; `None` means `2 n` (as Eigen). Default `None`.
    pub max_iter: Option<usize>,
    /// Starting point. Default [`InitialGuess::Zero`].
    pub initial_guess: InitialGuess,
    /// Record `|r_k| / |b|` of every iteration in [`CgInfo::residual_history`]
    /// (this allocates). Default `false`.
    pub record_history: bool,
    /// What a direction of non-positive curvature `p . A p <= 0` does (the
    /// matrix is not positive definite there). Default
    /// [`NegativeCurvature::Error`].
    pub negative_curvature: NegativeCurvature,
    /// Record CG's coefficients and return the extreme eigenvalues of
    /// `M^-1 A` and the condition estimate in [`CgInfo::condition`] (the
    /// Lanczos matrix's; [`ConditionEstimate`]). The coefficients of at most
    /// [`LANCZOS_CAPACITY`] iterations are kept, in the workspace (allocated
    /// once, before the first iteration); the estimate costs a bisection on
    /// that tridiagonal matrix at exit. Default `false`.
    pub estimate_condition: bool,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

/// What CG does on meeting a direction `p` with `p . A p <= 0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NegativeCurvature {
    /// Return [`SparseError::NotPositiveDefinite`] (or
    /// [`SparseError::PreconditionerNotPositiveDefinite`] for `r . M^-1 r <= 0`).
    #[default]
    Error,
    /// Truncated CG (the Newton-CG of Nocedal and Wright, Algorithm 7.1):
    /// stop and return the current iterate, which every earlier direction
    /// of positive curvature improved: a descent direction of the quadratic
    /// model `x . A x / 2 - b . x`; at the first iteration, the
    /// preconditioned residual step `x + M^-1 r`. A preconditioner that is
    /// not positive definite (`r . M^-1 r <= 0`) stops the run the same way,
    /// with the iterate so far. [`CgInfo::truncated`] is set and `converged`
    /// is not. For Newton on an indefinite Jacobian (the exact stiffness of
    /// compressed springs).
    Truncate,
}

impl Default for CgParams {
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol: 0.0,
            max_iter: None,
            initial_guess: InitialGuess::Zero,
            record_history: false,
            negative_curvature: NegativeCurvature::Error,
            estimate_condition: false,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// What a CG run did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CgInfo {
    /// Iterations performed (matrix-vector products after the initial
    /// residual, the true-residual checks not counted).
    pub iterations: usize,
    /// `|r|` of the recursively updated residual at exit.
    pub residual_norm: f64,
    /// `|r| / |b|` at exit (the reference norm is `|P b|` for filtered CG; when
    /// it is zero, the initial residual's norm).
    pub relative_residual: f64,
    /// The true residual `|P (b - A x)|` of the returned `x`, computed by a
    /// product with `A` at exit (the recursive `r` drifts from it by
    /// round-off, most on ill-conditioned systems at tight tolerances).
    pub true_residual_norm: f64,
    /// `true_residual_norm` over the reference norm of
    /// [`relative_residual`](Self::relative_residual).
    pub true_relative_residual: f64,
    /// Whether the tolerance was met by the true residual:
    /// `|P (b - A x)| <= max(rtol |P b|, atol)`.
    pub converged: bool,
    /// How often the recursive residual met the tolerance while the true
    /// one did not, and CG restarted from the true residual. A restart
    /// whose true residual is not below the last one's ends the run
    /// unconverged: the tolerance lies below the accuracy round-off allows
    /// (about `eps |A| |x| / |b|`).
    pub restarts: usize,
    /// Whether the callback stopped the run.
    pub stopped_by_callback: bool,
    /// Whether the run stopped on a direction of non-positive curvature
    /// ([`NegativeCurvature::Truncate`]); `residual_norm` is then the one of
    /// the last iterate of positive curvature (at the first iteration, of the
    /// starting guess).
    pub truncated: bool,
    /// `|r_k| / |b|` for k = 0, 1, ... when [`CgParams::record_history`] is set.
    pub residual_history: Vec<f64>,
    /// The extreme eigenvalues of `M^-1 A` (of `P M^-1 P A` on the free
    /// subspace for filtered CG) and their ratio, from the Lanczos matrix of
    /// the run's first segment (up to the first restart), when
    /// [`CgParams::estimate_condition`] is set and at least one iteration ran.
    pub condition: Option<ConditionEstimate>,
}

impl CgInfo {
    /// Turns a run that missed its tolerance into [`SparseError::NotConverged`].
    ///
    /// # Errors
    /// [`SparseError::NotConverged`] unless [`converged`](Self::converged).
    pub fn ensure_converged(self) -> Result<Self, SparseError> {
        if self.converged {
            Ok(self)
        } else {
            Err(SparseError::NotConverged {
                method: "PCG",
                iterations: self.iterations,
                relative_residual: self.true_relative_residual,
            })
        }
    }
}

/// The state a per-iteration callback sees.
#[derive(Debug)]
pub struct CgProgress<'a> {
    /// Iterations done so far.
    pub iteration: usize,
    /// `|r|`.
    pub residual_norm: f64,
    /// `|r| / |b|`.
    pub relative_residual: f64,
    /// The current iterate.
    pub x: &'a [f64],
}

/// A per-iteration callback: return `ControlFlow::Break(())` to stop.
pub type CgCallback<'a> = &'a mut dyn FnMut(&CgProgress<'_>) -> ControlFlow<()>;

/// The vectors CG needs besides `x` and `b`. Create once, reuse for every
/// solve of the same size: solves then allocate nothing.
#[derive(Debug, Clone, Default)]
pub struct CgWorkspace {
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    /// CG's step lengths and direction updates, for the condition estimate.
    lanczos: Lanczos,
}

/// The coefficients `alpha_j`, `beta_j` of one CG run (see
/// [`ConditionEstimate`]), in vectors whose capacity is reserved before
/// the iteration: recording never allocates.
#[derive(Debug, Clone, Default)]
struct Lanczos {
    alpha: Vec<f64>,
    beta: Vec<f64>,
    /// The Lanczos matrix's entries, written by [`Lanczos::estimate`].
    diagonal: Vec<f64>,
    off_squared: Vec<f64>,
    /// Whether the run still records (until its first restart).
    recording: bool,
    /// The iterations there is room for.
    room: usize,
}

impl Lanczos {
    /// Empties the record and reserves room for `steps` iterations
    /// (capped at [`LANCZOS_CAPACITY`]); `on` says whether to record.
    fn start(&mut self, on: bool, steps: usize) -> Result<(), SparseError> {
        self.alpha.clear();
        self.beta.clear();
        // Emptied here too, so that the room below is reserved from zero
        // (their last estimate's entries would count against it).
        self.diagonal.clear();
        self.off_squared.clear();
        self.recording = on;
        self.room = 0;
        if on {
            let room = steps.clamp(1, LANCZOS_CAPACITY);
            for v in [
                &mut self.alpha,
                &mut self.beta,
                &mut self.diagonal,
                &mut self.off_squared,
            ] {
                crate::error::try_grow("CG coefficients", v, room)?;
            }
            self.room = room;
        }
        Ok(())
    }

    /// Records one iteration's `alpha` and the `beta` that followed it,
    /// while there is room.
    #[inline]
    fn push(&mut self, alpha: f64, beta: f64) {
        if self.recording && self.alpha.len() < self.room {
            self.alpha.push(alpha);
            self.beta.push(beta);
        }
    }

    fn estimate(&mut self) -> Option<ConditionEstimate> {
        ConditionEstimate::from_cg_coefficients_in(
            &self.alpha,
            &self.beta,
            &mut self.diagonal,
            &mut self.off_squared,
        )
    }
}

impl CgWorkspace {
    /// A workspace for systems of dimension `n` (`32 n` bytes).
    ///
    /// # Panics
    /// If the allocator cannot give `32 n` bytes (as `Vec` does: a
    /// "capacity overflow" for `n` above `usize::MAX / 32`);
    /// [`try_new`](Self::try_new) returns an error instead.
    pub fn new(n: usize) -> Self {
        Self {
            r: vec![0.0; n],
            z: vec![0.0; n],
            p: vec![0.0; n],
            q: vec![0.0; n],
            lanczos: Lanczos::default(),
        }
    }

    /// A workspace for systems of dimension `n`, or an error where
    /// [`new`](Self::new) panics.
    ///
    /// # Errors
    /// [`SparseError::TooLarge`] if the four vectors cannot be allocated.
    pub fn try_new(n: usize) -> Result<Self, SparseError> {
        let what = "CG workspace";
        // All four at once first: no vector is allocated if they cannot all be.
        let total = n.checked_mul(4).ok_or(SparseError::TooLarge {
            what,
            entries: n,
            bytes: None,
        })?;
        crate::error::try_grow(what, &mut Vec::<f64>::new(), total)?;
        Ok(Self {
            r: crate::error::try_filled(what, n, 0.0)?,
            z: crate::error::try_filled(what, n, 0.0)?,
            p: crate::error::try_filled(what, n, 0.0)?,
            q: crate::error::try_filled(what, n, 0.0)?,
            lanczos: Lanczos::default(),
        })
    }

    fn ensure(&mut self, n: usize) -> Result<(), SparseError> {
        if self.r.len() != n {
            let lanczos = std::mem::take(&mut self.lanczos);
            *self = Self::try_new(n)?;
            self.lanczos = lanczos;
        }
        Ok(())
    }
}

/// A conjugate-gradient solver that owns its parameters and workspace: the
/// short form of [`pcg`] and [`filtered_pcg`] for code that solves many
/// systems of one size (the workspace is sized on first use and kept, so
/// later solves of that size allocate nothing).
///
/// ```
/// use hookean_sparse::{CgParams, Jacobi, Pcg, PreconditionerSetup, sprs};
/// let a = sprs::CsMat::new((2, 2), vec![0, 2, 4], vec![0, 1, 0, 1], vec![4.0, 1.0, 1.0, 3.0]);
/// let mut jacobi = Jacobi::new();
/// jacobi.setup(&a)?;
/// let mut x = [0.0; 2];
/// let info = Pcg::new(CgParams::default()).solve(&a, &jacobi, &[1.0, 2.0], &mut x)?;
/// assert!(info.converged);
/// assert!((x[0] - 1.0 / 11.0).abs() < 1e-12 && (x[1] - 7.0 / 11.0).abs() < 1e-12);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct Pcg {
    /// The parameters of every solve; change them between solves at will.
    pub params: CgParams,
    workspace: CgWorkspace,
}

impl Pcg {
    /// A solver with `params` and an empty workspace.
    pub fn new(params: CgParams) -> Self {
        Self {
            params,
            workspace: CgWorkspace::default(),
        }
    }

    /// Solves `A x = b` as [`pcg`] does.
    ///
    /// # Errors
    /// As [`pcg`].
    pub fn solve<A, P>(
        &mut self,
        a: &A,
        precond: &P,
        b: &[f64],
        x: &mut [f64],
    ) -> Result<CgInfo, SparseError>
    where
        A: LinearOperator + ?Sized,
        P: Preconditioner + ?Sized,
    {
        pcg(a, precond, b, x, &self.params, &mut self.workspace, None)
    }

    /// Solves `A x = b` under velocity constraints as [`filtered_pcg`] does.
    ///
    /// # Errors
    /// As [`filtered_pcg`].
    pub fn solve_filtered<A, P>(
        &mut self,
        a: &A,
        precond: &P,
        b: &[f64],
        x: &mut [f64],
        constraints: &Constraints,
    ) -> Result<CgInfo, SparseError>
    where
        A: LinearOperator + ?Sized,
        P: Preconditioner + ?Sized,
    {
        let (params, workspace) = (&self.params, &mut self.workspace);
        filtered_pcg(a, precond, b, x, constraints, params, workspace, None)
    }
}

/// Preconditioned conjugate gradients for `A x = b`, `A` symmetric positive definite.
///
/// Returns [`CgInfo`] with `converged = false` when the iteration limit is
/// hit (use [`CgInfo::ensure_converged`] to make that an error).
///
/// # Errors
/// [`SparseError::DimensionMismatch`] for wrong sizes (of `b`, `x`, the
/// preconditioner), [`SparseError::NonFinite`] for NaN or infinite input or
/// iterates, [`SparseError::NotPositiveDefinite`] when `p^T A p <= 0`,
/// [`SparseError::PreconditionerNotPositiveDefinite`] when `r^T M^-1 r <= 0`
/// (the preconditioner is not positive definite).
///
/// ```
/// use hookean_sparse::{pcg, CgParams, CgWorkspace, Jacobi, MatrixFree, PreconditionerSetup};
/// let a = sprs::CsMat::new((2, 2), vec![0, 2, 4], vec![0, 1, 0, 1], vec![4.0, 1.0, 1.0, 3.0]);
/// let mut jacobi = Jacobi::new();
/// jacobi.setup(&a)?;
/// let b = [1.0, 2.0];
/// let mut x = [0.0; 2];
/// let info = pcg(&a, &jacobi, &b, &mut x, &CgParams::default(), &mut CgWorkspace::new(2), None)?;
/// assert!(info.converged);
/// assert!((x[0] - 1.0 / 11.0).abs() < 1e-12 && (x[1] - 7.0 / 11.0).abs() < 1e-12);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
pub fn pcg<A, P>(
    a: &A,
    precond: &P,
    b: &[f64],
    x: &mut [f64],
    params: &CgParams,
    workspace: &mut CgWorkspace,
    callback: Option<CgCallback<'_>>,
) -> Result<CgInfo, SparseError>
where
    A: LinearOperator + ?Sized,
    P: Preconditioner + ?Sized,
{
    run(a, precond, b, x, &NoFilter, params, workspace, callback)
}

/// Filtered PCG (Baraff-Witkin; the tutorial's Algorithm 4, whose `while`
/// condition is printed inverted: iterate *while* `|r| / |b| > eps`).
///
/// Solves `P A P x = P b` subject to `(I - P) x` equal to the prescribed
/// constraint values: the result honours the constraints exactly and solves
/// the system in the free directions. The initial guess is filtered and the
/// prescribed values imposed before the first residual; every search
/// direction and every `A p` is filtered, so no update leaves the free subspace.
///
/// # Errors
/// As [`pcg`], plus [`SparseError::DimensionMismatch`] if the constraints are
/// for another number of particles.
pub fn filtered_pcg<A, P>(
    a: &A,
    precond: &P,
    b: &[f64],
    x: &mut [f64],
    constraints: &Constraints,
    params: &CgParams,
    workspace: &mut CgWorkspace,
    callback: Option<CgCallback<'_>>,
) -> Result<CgInfo, SparseError>
where
    A: LinearOperator + ?Sized,
    P: Preconditioner + ?Sized,
{
    if 3 * constraints.n_particles() != a.nrows() {
        return Err(SparseError::DimensionMismatch {
            what: "constraints (3 x particles)",
            expected: a.nrows(),
            found: 3 * constraints.n_particles(),
        });
    }
    run(a, precond, b, x, constraints, params, workspace, callback)
}

/// The projector of filtered CG; `NoFilter` compiles to nothing.
trait Filter {
    fn project(&self, v: &mut [f64]);
    fn impose(&self, x: &mut [f64]);
}

struct NoFilter;

impl Filter for NoFilter {
    #[inline(always)]
    fn project(&self, _v: &mut [f64]) {}
    #[inline(always)]
    fn impose(&self, _x: &mut [f64]) {}
}

impl Filter for Constraints {
    #[inline]
    fn project(&self, v: &mut [f64]) {
        Constraints::project(self, v)
    }
    #[inline]
    fn impose(&self, x: &mut [f64]) {
        Constraints::impose(self, x)
    }
}

#[allow(clippy::too_many_arguments)]
fn run<A, P, F>(
    a: &A,
    precond: &P,
    b: &[f64],
    x: &mut [f64],
    filter: &F,
    params: &CgParams,
    ws: &mut CgWorkspace,
    mut callback: Option<CgCallback<'_>>,
) -> Result<CgInfo, SparseError>
where
    A: LinearOperator + ?Sized,
    P: Preconditioner + ?Sized,
    F: Filter,
{
    let n = a.nrows();
    crate::error::non_empty("matrix", n)?;
    check_len("right-hand side b", b, n)?;
    check_len("solution x", x, n)?;
    if let Some(d) = precond.dim()
        && d != n
    {
        return Err(SparseError::DimensionMismatch {
            what: "preconditioner (was it set up for this matrix?)",
            expected: n,
            found: d,
        });
    }
    let tolerance = |t: f64| t >= 0.0 && t.is_finite();
    if !(tolerance(params.rtol) && tolerance(params.atol)) {
        return Err(SparseError::InvalidParameter {
            name: "tolerance",
            message: format!(
                "rtol and atol must be finite non-negative numbers, got {:?} and {:?}",
                params.rtol, params.atol
            ),
        });
    }
    check_finite("right-hand side b", b)?;
    match params.initial_guess {
        InitialGuess::Zero => x.fill(0.0),
        InitialGuess::Given => check_finite("initial guess x", x)?,
    }
    let max_iter = params.max_iter.unwrap_or(2 * n);
    ws.ensure(n)?;
    let CgWorkspace {
        r,
        z,
        p,
        q,
        lanczos,
    } = ws;
    lanczos.start(params.estimate_condition, max_iter)?;

    filter.impose(x);
    // r = P (b - A x); the reference norm is |P b|. A zero start (with
    // homogeneous constraints, x is still zero) needs no product.
    if params.initial_guess == InitialGuess::Zero && x.iter().all(|&v| v == 0.0) {
        r.copy_from_slice(b);
    } else {
        a.apply(x, q);
        for i in 0..n {
            r[i] = b[i] - q[i];
        }
    }
    filter.project(r);
    z.copy_from_slice(b);
    filter.project(z);
    let b_norm = norm2(z);
    check_scale("right-hand side b", z)?;
    let mut r_norm = norm2(r);
    check_finite_scalar("initial residual", r_norm)?;
    let reference = if b_norm > 0.0 { b_norm } else { r_norm };
    let rel = |rn: f64| if reference > 0.0 { rn / reference } else { 0.0 };
    let threshold = (params.rtol * reference).max(params.atol);

    let mut info = CgInfo::default();
    if params.record_history {
        info.residual_history.push(rel(r_norm));
    }
    // z = P M^-1 r and r . z (r lies in range(P), so r . P z = r . z); not
    // needed when the start already meets the tolerance.
    let mut rz = if r_norm <= threshold && precond.costly() {
        0.0
    } else {
        precond.apply_dot(r, z)
    };
    filter.project(z);
    // |r| one iteration back: the last residual reduction predicts whether
    // the next iteration ends the solve (see `likely_last` below).
    let mut r_norm_prev = f64::NAN;
    p.fill(0.0);
    let mut beta = 0.0;
    // The step x += alpha p of an iteration is applied inside the next
    // iteration's fused SpMV (which reads p anyway); `pending` is its alpha,
    // applied directly whenever x must be current (exit, callback).
    let mut pending = 0.0;
    let mut k = 0;
    // Whether `r` is the true residual of `x` (computed by a product, not
    // updated by recursion): at the start and after a restart.
    let mut r_is_true = true;
    // The true residual of the last restart (none yet).
    let mut last_restart_norm = f64::INFINITY;
    loop {
        if pending != 0.0 && (r_norm <= threshold || k >= max_iter || callback.is_some()) {
            for (xi, pi) in x.iter_mut().zip(p.iter()) {
                *xi += pending * pi;
            }
            pending = 0.0;
        }
        info.iterations = k;
        info.residual_norm = r_norm;
        info.relative_residual = rel(r_norm);
        if r_norm <= threshold {
            if r_is_true {
                info.converged = true;
                break;
            }
            // The recursive residual says done: check the true one (one
            // product per solve that claims convergence).
            let true_norm = true_residual(a, filter, b, x, q);
            check_finite_scalar("true residual", true_norm)?;
            if true_norm <= threshold {
                info.converged = true;
                info.true_residual_norm = true_norm;
                info.true_relative_residual = rel(true_norm);
                info.condition = lanczos.estimate();
                return Ok(info);
            }
            // It drifted. A restart that did not lower the true residual
            // below the last restart's means CG has reached the accuracy
            // round-off allows: stop, not converged.
            if !(true_norm < last_restart_norm) {
                info.true_residual_norm = true_norm;
                info.true_relative_residual = rel(true_norm);
                info.condition = lanczos.estimate();
                return Ok(info);
            }
            last_restart_norm = true_norm;
            // A restart begins a new Krylov space: the Lanczos matrix of
            // the first segment is the estimate.
            lanczos.recording = false;
            // Restart CG from the true residual (iterating on with the
            // recursive one would stop again at once).
            r.copy_from_slice(q);
            r_norm = true_norm;
            r_is_true = true;
            info.restarts += 1;
            info.residual_norm = r_norm;
            info.relative_residual = rel(r_norm);
            rz = precond.apply_dot(r, z);
            filter.project(z);
            beta = 0.0;
            r_norm_prev = f64::NAN;
        }
        if let Some(cb) = callback.as_mut() {
            let progress = CgProgress {
                iteration: k,
                residual_norm: r_norm,
                relative_residual: rel(r_norm),
                x,
            };
            if cb(&progress).is_break() {
                info.stopped_by_callback = true;
                break;
            }
        }
        if k >= max_iter {
            break;
        }
        if params.negative_curvature == NegativeCurvature::Truncate && rz <= 0.0 {
            // An indefinite preconditioner (e.g. block Jacobi of an
            // indefinite diagonal block): no direction to go on.
            info.truncated = true;
            break;
        }
        check_preconditioned(rz, k)?;
        // x += pending p; p = z + beta p; q = P A p; p . q (p lies in range(P):
        // p . A p = p . P A p).
        let pq = a.update_and_apply_dot(z, beta, pending, x, p, q);
        filter.project(q);
        if !pq.is_finite() {
            return Err(SparseError::NonFinite {
                what: "CG iterate (A p)",
                index: None,
            });
        }
        if pq <= 0.0 {
            if params.negative_curvature == NegativeCurvature::Truncate {
                // x already holds the last iterate (the fused product applied
                // `pending`); at k = 0, p = P M^-1 r.
                if k == 0 {
                    for (xi, pi) in x.iter_mut().zip(p.iter()) {
                        *xi += pi;
                    }
                    r_is_true = false;
                }
                info.iterations = k;
                info.truncated = true;
                break;
            }
            return Err(SparseError::NotPositiveDefinite {
                iteration: k,
                curvature: pq,
            });
        }
        let alpha = rz / pq;
        pending = alpha;
        // r -= alpha q; z = M^-1 r; one pass for pointwise preconditioners
        // (and the multigrid's pre-smoothing). The iteration that meets the
        // tolerance, or the last one allowed, never uses its z: where the
        // last reduction of |r| predicts that, |r| is updated first and the
        // preconditioner applied only if the solve goes on (a V-cycle saved
        // per solve for one more pass over r and q).
        let likely_last = precond.costly()
            && (k + 1 >= max_iter || r_norm * (r_norm / r_norm_prev) <= LIKELY_LAST * threshold);
        r_norm_prev = r_norm;
        let (rr, rz_new) = if likely_last {
            let rr = update_residual(alpha, q, r);
            if rr.sqrt() <= threshold || k + 1 >= max_iter {
                (rr, rz)
            } else {
                (rr, precond.apply_dot(r, z))
            }
        } else {
            precond.update_and_apply(alpha, q, r, z)
        };
        filter.project(z);
        r_norm = rr.sqrt();
        r_is_true = false;
        beta = rz_new / rz;
        lanczos.push(alpha, beta);
        rz = rz_new;
        k += 1;
        if params.record_history {
            info.residual_history.push(rel(r_norm));
        }
    }
    // An unconverged exit (the iteration limit, the callback, a truncation)
    // reports the true residual of the `x` it returns too.
    let true_norm = if r_is_true {
        r_norm
    } else {
        true_residual(a, filter, b, x, q)
    };
    info.true_residual_norm = true_norm;
    info.true_relative_residual = rel(true_norm);
    info.condition = lanczos.estimate();
    Ok(info)
}

/// `|P (b - A x)|`, the residual left in `out`.
fn true_residual<A, F>(a: &A, filter: &F, b: &[f64], x: &[f64], out: &mut [f64]) -> f64
where
    A: LinearOperator + ?Sized,
    F: Filter,
{
    a.apply(x, out);
    for (o, bi) in out.iter_mut().zip(b) {
        *o = bi - *o;
    }
    filter.project(out);
    norm2(out)
}

/// How far above the tolerance the predicted next `|r|` (the last one
/// times the last reduction factor) may lie for CG to test `|r|` before
/// applying the preconditioner: a wrong guess costs one pass over two
/// vectors, a right one a preconditioner application (a V-cycle).
const LIKELY_LAST: f64 = 2.0;

/// `r . M^-1 r` must be positive and finite for a usable preconditioner.
fn check_preconditioned(rz: f64, iteration: usize) -> Result<(), SparseError> {
    if !rz.is_finite() {
        return Err(SparseError::NonFinite {
            what: "preconditioned residual",
            index: None,
        });
    }
    if rz <= 0.0 {
        return Err(SparseError::PreconditionerNotPositiveDefinite {
            iteration,
            value: rz,
        });
    }
    Ok(())
}

/// Refuses a non-zero vector whose largest entry lies outside
/// `[1e-150, 1e150]`: the squares of CG's inner products would underflow
/// to zero (reporting convergence at `x = 0`) or overflow.
pub(crate) fn check_scale(what: &'static str, v: &[f64]) -> Result<(), SparseError> {
    let largest = crate::vecops::norm_inf(v);
    if largest == 0.0 || (1e-150..=1e150).contains(&largest) {
        Ok(())
    } else {
        Err(SparseError::BadlyScaled { what, largest })
    }
}

fn check_finite_scalar(what: &'static str, v: f64) -> Result<(), SparseError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SparseError::NonFinite { what, index: None })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::precond::testutil::*;
    use crate::{Identity, IncompleteCholesky, Jacobi, PreconditionerSetup};

    #[test]
    fn pcg_solves_to_the_requested_tolerance_with_every_preconditioner() {
        let a = spd_block_matrix(4, 4);
        let d = dense(&a);
        let b = rhs(a.dim());
        let exact = dense_solve(&d, &b);
        let mut ws = CgWorkspace::new(a.dim());
        for kind in crate::PrecondKind::all(1.2) {
            let mut p = crate::AnyPreconditioner::new(kind).unwrap();
            p.setup(&a).unwrap();
            let mut x = vec![0.0; a.dim()];
            let params = CgParams {
                rtol: 1e-10,
                ..Default::default()
            };
            let info = pcg(&a, &p, &b, &mut x, &params, &mut ws, None).unwrap();
            assert!(info.converged, "{kind}");
            // The true residual, not the recursive one.
            let mut ax = vec![0.0; a.dim()];
            a.mul_vec(&x, &mut ax).unwrap();
            let res: Vec<f64> = ax.iter().zip(&b).map(|(u, v)| u - v).collect();
            assert!(norm2(&res) <= 1e-9 * norm2(&b), "{kind}");
            assert!(rel_diff(&x, &exact) < 1e-8, "{kind}");
        }
    }

    /// A preconditioner that counts its applications and claims to be costly or not.
    struct Counted<'a> {
        inner: &'a IncompleteCholesky,
        costly: bool,
        applications: std::sync::atomic::AtomicUsize,
    }

    impl Preconditioner for Counted<'_> {
        fn dim(&self) -> Option<usize> {
            self.inner.dim()
        }
        fn apply(&self, r: &[f64], z: &mut [f64]) {
            self.applications
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.inner.apply(r, z);
        }
        fn costly(&self) -> bool {
            self.costly
        }
    }

    #[test]
    fn a_costly_preconditioner_is_not_applied_in_the_iteration_that_converges() {
        let a = spd_block_matrix(12, 12);
        let b = rhs(a.dim());
        let mut ic = IncompleteCholesky::new();
        ic.setup(&a).unwrap();
        let mut ws = CgWorkspace::new(a.dim());
        let solve = |costly: bool, rtol: f64, max_iter: Option<usize>, ws: &mut CgWorkspace| {
            let p = Counted {
                inner: &ic,
                costly,
                applications: 0.into(),
            };
            let mut x = vec![0.0; a.dim()];
            let params = CgParams {
                rtol,
                max_iter,
                ..Default::default()
            };
            let info = pcg(&a, &p, &b, &mut x, &params, ws, None).unwrap();
            (info, x, p.applications.into_inner())
        };
        for rtol in [1e-2, 1e-6, 1e-10] {
            let (cheap, x_cheap, n_cheap) = solve(false, rtol, None, &mut ws);
            let (costly, x_costly, n_costly) = solve(true, rtol, None, &mut ws);
            assert!(cheap.converged && costly.converged, "rtol {rtol}");
            assert!(cheap.iterations >= 2, "rtol {rtol}: a test of nothing");
            // The same iterates (the same r . z, p . A p): the fused pass
            // applies M^-1 once per iteration plus the start's.
            assert_eq!(costly.iterations, cheap.iterations, "rtol {rtol}");
            assert_eq!(x_costly, x_cheap, "rtol {rtol}");
            assert_eq!(n_cheap, cheap.iterations + 1, "rtol {rtol}");
            // The converging iteration tests |r| first and skips its application.
            assert_eq!(n_costly, costly.iterations, "rtol {rtol}");
            // The true residual meets the tolerance.
            let mut ax = vec![0.0; a.dim()];
            a.mul_vec(&x_costly, &mut ax).unwrap();
            let res: Vec<f64> = ax.iter().zip(&b).map(|(u, v)| u - v).collect();
            assert!(norm2(&res) <= 1.01 * rtol * norm2(&b), "rtol {rtol}");
        }
        // The last iteration allowed never applies it either.
        let (info, _, n) = solve(true, 1e-14, Some(3), &mut ws);
        assert!(!info.converged);
        assert_eq!((info.iterations, n), (3, 3));
        // A start that already meets the tolerance: no application at all.
        let (info, _, n) = solve(true, 2.0, None, &mut ws);
        assert_eq!((info.iterations, n), (0, 0));
    }

    #[test]
    fn cg_without_preconditioner_terminates_in_n_steps_in_exact_arithmetic_terms() {
        // A diagonal matrix with 3 distinct eigenvalues: CG converges in 3 iterations.
        let n = 9;
        let a = crate::MatrixFree::new(n, |x: &[f64], y: &mut [f64]| {
            for i in 0..x.len() {
                y[i] = (1 + i % 3) as f64 * x[i];
            }
        });
        let b = vec![1.0; n];
        let mut x = vec![0.0; n];
        let info = pcg(
            &a,
            &Identity,
            &b,
            &mut x,
            &CgParams {
                rtol: 1e-12,
                ..Default::default()
            },
            &mut CgWorkspace::new(n),
            None,
        )
        .unwrap();
        assert_eq!(info.iterations, 3);
        for i in 0..n {
            approx::assert_abs_diff_eq!(x[i], 1.0 / (1 + i % 3) as f64, epsilon = 1e-12);
        }
    }

    #[test]
    fn warm_start_from_the_solution_needs_no_iteration() {
        let a = spd_block_matrix(2, 2);
        let b = rhs(a.dim());
        let mut x = dense_solve(&dense(&a), &b);
        let mut j = Jacobi::new();
        j.setup(&a).unwrap();
        let params = CgParams {
            rtol: 1e-8,
            initial_guess: InitialGuess::Given,
            ..Default::default()
        };
        let info = pcg(
            &a,
            &j,
            &b,
            &mut x,
            &params,
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap();
        assert_eq!(info.iterations, 0);
        assert!(info.converged);
    }

    #[test]
    fn callback_sees_every_iteration_and_can_stop() {
        let a = spd_block_matrix(4, 4);
        let b = rhs(a.dim());
        let mut x = vec![0.0; a.dim()];
        let mut seen = Vec::new();
        let mut cb = |p: &CgProgress<'_>| {
            seen.push(p.iteration);
            if p.iteration == 3 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        let info = pcg(
            &a,
            &Identity,
            &b,
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::default(),
            Some(&mut cb),
        )
        .unwrap();
        assert_eq!(seen, vec![0, 1, 2, 3]);
        assert!(info.stopped_by_callback && !info.converged);
        assert_eq!(info.iterations, 3);
    }

    #[test]
    fn residual_history_decreases_to_the_tolerance() {
        let a = spd_block_matrix(3, 3);
        let b = rhs(a.dim());
        let mut x = vec![0.0; a.dim()];
        let mut ic = IncompleteCholesky::new();
        ic.setup(&a).unwrap();
        let params = CgParams {
            record_history: true,
            ..Default::default()
        };
        let info = pcg(
            &a,
            &ic,
            &b,
            &mut x,
            &params,
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap();
        assert_eq!(info.residual_history.len(), info.iterations + 1);
        assert_eq!(info.residual_history[0], 1.0);
        assert!(*info.residual_history.last().unwrap() <= 1e-8);
    }

    #[test]
    fn iteration_limit_gives_unconverged_info_and_a_typed_error_on_request() {
        let a = spd_block_matrix(4, 4);
        let b = rhs(a.dim());
        let mut x = vec![0.0; a.dim()];
        let params = CgParams {
            max_iter: Some(2),
            ..Default::default()
        };
        let info = pcg(
            &a,
            &Identity,
            &b,
            &mut x,
            &params,
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap();
        assert!(!info.converged);
        assert_eq!(info.iterations, 2);
        assert!(matches!(
            info.ensure_converged(),
            Err(SparseError::NotConverged { iterations: 2, .. })
        ));
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let a = spd_block_matrix(2, 2);
        let n = a.dim();
        let mut ws = CgWorkspace::default();
        let p = CgParams::default();
        let mut x = vec![0.0; n];
        assert!(matches!(
            pcg(&a, &Identity, &vec![1.0; n - 1], &mut x, &p, &mut ws, None),
            Err(SparseError::DimensionMismatch { .. })
        ));
        let mut b = vec![1.0; n];
        b[3] = f64::NAN;
        assert_eq!(
            pcg(&a, &Identity, &b, &mut x, &p, &mut ws, None),
            Err(SparseError::NonFinite {
                what: "right-hand side b",
                index: Some(3)
            })
        );
        let j = Jacobi::new(); // never set up
        assert!(matches!(
            pcg(&a, &j, &vec![1.0; n], &mut x, &p, &mut ws, None),
            Err(SparseError::DimensionMismatch { .. })
        ));
        let bad = CgParams {
            rtol: f64::NAN,
            ..Default::default()
        };
        assert!(matches!(
            pcg(&a, &Identity, &vec![1.0; n], &mut x, &bad, &mut ws, None),
            Err(SparseError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn indefinite_matrix_is_not_positive_definite() {
        let a = crate::MatrixFree::new(2, |x: &[f64], y: &mut [f64]| {
            y[0] = x[0];
            y[1] = -x[1];
        });
        let mut x = [0.0; 2];
        let err = pcg(
            &a,
            &Identity,
            &[0.0, 1.0],
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap_err();
        assert!(
            matches!(err, SparseError::NotPositiveDefinite { iteration: 0, curvature } if curvature < 0.0)
        );
    }

    #[test]
    fn zero_rhs_gives_zero_solution_at_once() {
        let a = spd_block_matrix(2, 2);
        let mut x = vec![5.0; a.dim()];
        let info = pcg(
            &a,
            &Identity,
            &vec![0.0; a.dim()],
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap();
        assert!(info.converged && info.iterations == 0);
        assert!(x.iter().all(|&v| v == 0.0));
    }

    /// Solves the reduced system on the free directions densely: with an
    /// orthonormal basis `F` of range(P), `x = x_c + F y`,
    /// `(F^T A F) y = F^T (b - A x_c)`.
    fn reduced_solve(d: &[Vec<f64>], b: &[f64], c: &Constraints) -> Vec<f64> {
        let n = b.len();
        let mut xc = vec![0.0; n];
        c.impose(&mut xc);
        // Basis of range(P): project unit vectors and orthonormalise.
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for i in 0..n {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            c.project(&mut e);
            for f in &basis {
                let s: f64 = e.iter().zip(f).map(|(u, v)| u * v).sum();
                for (ei, fi) in e.iter_mut().zip(f) {
                    *ei -= s * fi;
                }
            }
            let len = norm2(&e);
            if len > 1e-8 {
                basis.push(e.iter().map(|v| v / len).collect());
            }
        }
        let m = basis.len();
        let axc: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| d[i][j] * xc[j]).sum())
            .collect();
        let af: Vec<Vec<f64>> = basis
            .iter()
            .map(|f| {
                (0..n)
                    .map(|i| (0..n).map(|j| d[i][j] * f[j]).sum())
                    .collect()
            })
            .collect();
        let red: Vec<Vec<f64>> = (0..m)
            .map(|i| {
                (0..m)
                    .map(|j| basis[i].iter().zip(&af[j]).map(|(u, v)| u * v).sum())
                    .collect()
            })
            .collect();
        let rhs: Vec<f64> = (0..m)
            .map(|i| {
                basis[i]
                    .iter()
                    .zip(b.iter().zip(&axc))
                    .map(|(f, (bb, ax))| f * (bb - ax))
                    .sum()
            })
            .collect();
        let y = dense_solve(&red, &rhs);
        let mut x = xc;
        for (f, yi) in basis.iter().zip(&y) {
            for (xi, fi) in x.iter_mut().zip(f) {
                *xi += yi * fi;
            }
        }
        x
    }

    #[test]
    fn filtered_pcg_matches_the_reduced_system_and_honours_constraints() {
        let a = spd_block_matrix(3, 3);
        let d = dense(&a);
        let b = rhs(a.dim());
        let mut c = Constraints::new(a.n_blocks());
        c.pin(0, [0.1, -0.2, 0.3]).unwrap();
        c.constrain(4, [0.0, 0.0, 1.0], 0.5).unwrap();
        c.constrain(7, [1.0, 1.0, 0.0], -0.25).unwrap();
        c.constrain(7, [0.0, 1.0, 1.0], 0.0).unwrap();
        let expected = reduced_solve(&d, &b, &c);
        for kind in crate::PrecondKind::all(1.0) {
            let mut p = crate::AnyPreconditioner::new(kind).unwrap();
            p.setup(&a).unwrap();
            let mut x = vec![1.0; a.dim()];
            let params = CgParams {
                rtol: 1e-12,
                initial_guess: InitialGuess::Given,
                ..Default::default()
            };
            let info = filtered_pcg(
                &a,
                &p,
                &b,
                &mut x,
                &c,
                &params,
                &mut CgWorkspace::default(),
                None,
            )
            .unwrap();
            assert!(info.converged, "{kind}");
            assert!(c.violation(&x) < 1e-14, "{kind}");
            assert!(
                rel_diff(&x, &expected) < 1e-9,
                "{kind}: {}",
                rel_diff(&x, &expected)
            );
        }
    }

    #[test]
    fn filtered_pcg_with_no_constraints_is_pcg() {
        let a = spd_block_matrix(3, 2);
        let b = rhs(a.dim());
        let c = Constraints::new(a.n_blocks());
        let (mut x1, mut x2) = (vec![0.0; a.dim()], vec![0.0; a.dim()]);
        let p = CgParams::default();
        let i1 = pcg(
            &a,
            &Identity,
            &b,
            &mut x1,
            &p,
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap();
        let i2 = filtered_pcg(
            &a,
            &Identity,
            &b,
            &mut x2,
            &c,
            &p,
            &mut CgWorkspace::default(),
            None,
        )
        .unwrap();
        assert_eq!(x1, x2);
        assert_eq!(i1, i2);
    }

    #[test]
    fn constraints_of_the_wrong_size_are_an_error() {
        let a = spd_block_matrix(2, 2);
        let c = Constraints::new(3);
        let mut x = vec![0.0; a.dim()];
        assert!(matches!(
            filtered_pcg(
                &a,
                &Identity,
                &vec![1.0; a.dim()],
                &mut x,
                &c,
                &CgParams::default(),
                &mut CgWorkspace::default(),
                None
            ),
            Err(SparseError::DimensionMismatch { .. })
        ));
    }

    /// On an indefinite matrix CG either fails (the default) or, truncated,
    /// returns an iterate that lowers the quadratic model
    /// `q(x) = x . A x / 2 - b . x` below `q(0) = 0` (Newton-CG's descent
    /// property: every step taken had positive curvature).
    #[test]
    fn truncated_cg_stops_at_negative_curvature_with_a_descent_iterate() {
        use std::sync::Arc;
        // Two particles, A = diag(4, 3, 2, 1, 0.5, -1) plus a coupling.
        let pattern = Arc::new(crate::BlockPattern::new(2, [(0, 1)]).unwrap());
        let mut a = crate::SymBlockMatrix::new(pattern);
        a.add_to_diagonal(&[4.0, 3.0, 2.0, 1.0, 0.5, -1.0]).unwrap();
        a.add_to_block(0, 1, &[[0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.1]])
            .unwrap();
        let b = [1.0, -1.0, 1.0, 1.0, -1.0, 1.0];
        let mut ws = CgWorkspace::new(6);
        let mut x = [0.0; 6];
        let strict = CgParams {
            rtol: 1e-12,
            ..Default::default()
        };
        assert!(matches!(
            pcg(&a, &Identity, &b, &mut x, &strict, &mut ws, None),
            Err(SparseError::NotPositiveDefinite { .. })
        ));
        let truncate = CgParams {
            negative_curvature: NegativeCurvature::Truncate,
            ..strict
        };
        let info = pcg(&a, &Identity, &b, &mut x, &truncate, &mut ws, None).unwrap();
        assert!(info.truncated && !info.converged);
        assert!(
            info.iterations >= 1,
            "positive curvature came first: {info:?}"
        );
        let mut ax = [0.0; 6];
        a.mul_vec(&x, &mut ax).unwrap();
        let q: f64 = (0..6).map(|i| 0.5 * x[i] * ax[i] - b[i] * x[i]).sum();
        assert!(q < 0.0, "q(x) = {q}");
        // An SPD matrix never truncates.
        let mut spd = a.clone();
        spd.add_to_diagonal(&[0.0, 0.0, 0.0, 0.0, 0.0, 2.0])
            .unwrap();
        let info = pcg(&spd, &Identity, &b, &mut x, &truncate, &mut ws, None).unwrap();
        assert!(info.converged && !info.truncated);
    }
}
