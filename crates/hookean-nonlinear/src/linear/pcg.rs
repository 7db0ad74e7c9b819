//! [`PcgSolver`]: preconditioned conjugate gradients for symmetric positive
//! definite Jacobians, with the options it owns ([`PcgOptions`]).

use crate::NonExhaustive;
use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, Constraints, InitialGuess, LinearOperator,
    NegativeCurvature, PreconditionerOptions, PreconditionerSetup, filtered_pcg, pcg,
};

use super::record::{RecordedSolve, RecorderSlot, SharedRecorder};
use super::{LinearSolveStats, LinearSolver};
use crate::error::{NonlinearError, check_len, invalid};

/// The settings of a [`PcgSolver`] over [`AnyPreconditioner`]: which
/// preconditioner with its settings, the iteration limit and what a
/// direction of non-positive curvature does. Every field has a documented
/// default; a solver with a fixed preconditioner type takes the last two
/// through [`PcgSolver::with_max_iter`] and
/// [`PcgSolver::with_negative_curvature`].
#[derive(Debug, Clone, PartialEq)]
pub struct PcgOptions {
    /// The preconditioner with its settings (the multigrid's options
    /// included). Default block-Jacobi ([`PreconditionerOptions::default`]).
    pub preconditioner: PreconditionerOptions,
    /// Iteration limit of each solve; `None` means `2 n`. Default `None`.
    pub max_iter: Option<usize>,
    /// What PCG does on a direction of non-positive curvature: fail the
    /// solve (the Newton iteration stops, default), or truncate it and
    /// return the iterate so far, which Newton takes as its correction,
    /// shortened by a backtracking line search until `|G|` falls
    /// ([`NegativeCurvature::Truncate`], Newton-CG). That lets Newton use an
    /// exact Jacobian that is indefinite (compressed springs); the
    /// preconditioner must stay positive definite (MIC(0)'s shift keeps it so).
    pub negative_curvature: NegativeCurvature,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for PcgOptions {
    fn default() -> Self {
        Self {
            preconditioner: PreconditionerOptions::default(),
            max_iter: None,
            negative_curvature: NegativeCurvature::Error,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// Preconditioned conjugate gradients ([`hookean_sparse::pcg`]) for
/// symmetric positive definite Jacobians, e.g. the cloth matrix
/// `M - h df/dv - h^2 df/dx` (the tutorial's section 4): the one Krylov
/// adapter of the workspace (the integrators of `hookean-ode` use it too).
///
/// Works for every Jacobian type `A` that is a [`LinearOperator`] and that
/// the preconditioner `P` can be set up from
/// ([`SymBlockMatrix`](hookean_sparse::SymBlockMatrix) and `sprs::CsMat<f64>`
/// with every hookean-sparse preconditioner; any operator with
/// [`Identity`](hookean_sparse::Identity)). With `P =`
/// [`AnyPreconditioner`] it is built from [`PcgOptions`]
/// ([`from_options`](PcgSolver::from_options)).
///
/// **Constraints.** With [`constraints`](Self::with_constraints), the
/// filtered PCG of Baraff-Witkin (the tutorial's Algorithm 4) solves for
/// Newton *corrections* that keep the constrained components unchanged:
/// with `z` the prescribed values, `A s' = rhs + A z` is solved with `s'`
/// taking the values `z`, and `s = s' - z` has zero constrained components
/// (for homogeneous constraints such as pins `z = 0` and no product is
/// needed). The initial iterate should satisfy the constraints, and the
/// residual `G` of such a system should be filtered (`G <- P G`) so that
/// Newton's convergence test sees only the free directions.
///
/// **Warm start.** Every solve starts from zero unless a guess was armed
/// with [`arm_guess`](Self::arm_guess) (used by the next solve only), e.g.
/// the previous time step's correction.
///
/// **Recording.** With [`set_recorder`](Self::set_recorder), every solve is
/// handed to a [`SolveRecorder`](crate::SolveRecorder) after it ran (its
/// matrix, right-hand side, start, constraints, tolerance and result).
#[derive(Debug, Clone)]
pub struct PcgSolver<P> {
    precond: P,
    /// Iteration limit per solve; `None` means `2 n` ([`PcgOptions::max_iter`]).
    max_iter: Option<usize>,
    /// [`PcgOptions::negative_curvature`].
    negative_curvature: NegativeCurvature,
    constraints: Option<Constraints>,
    workspace: CgWorkspace,
    /// The prescribed values `z` and the shifted right-hand side `rhs + A z`.
    z: Vec<f64>,
    shifted_rhs: Vec<f64>,
    /// The starting guess of the next solve, if armed.
    guess: Vec<f64>,
    use_guess: bool,
    /// Whether `setup` ran since the last solve (for the recorder).
    set_up: bool,
    recorder: RecorderSlot,
}

impl<P> PcgSolver<P> {
    /// A PCG solver with the given (not yet set up) preconditioner, at most
    /// `2 n` iterations per solve and failing on non-positive curvature.
    pub fn new(precond: P) -> Self {
        Self {
            precond,
            max_iter: None,
            negative_curvature: NegativeCurvature::Error,
            constraints: None,
            workspace: CgWorkspace::default(),
            z: Vec::new(),
            shifted_rhs: Vec::new(),
            guess: Vec::new(),
            use_guess: false,
            set_up: false,
            recorder: RecorderSlot::default(),
        }
    }

    /// Hands every later solve to `recorder` (`None`: no more recording).
    pub fn set_recorder(&mut self, recorder: Option<SharedRecorder>) {
        self.recorder = RecorderSlot(recorder);
    }

    /// With the iteration limit `max_iter` (`None`: `2 n`) per solve.
    pub fn with_max_iter(mut self, max_iter: Option<usize>) -> Self {
        self.max_iter = max_iter;
        self
    }

    /// With the policy on directions of non-positive curvature
    /// ([`PcgOptions::negative_curvature`]).
    pub fn with_negative_curvature(mut self, negative_curvature: NegativeCurvature) -> Self {
        self.negative_curvature = negative_curvature;
        self
    }

    /// Uses filtered PCG with these constraints (see the type's docs).
    pub fn with_constraints(mut self, constraints: Constraints) -> Self {
        self.constraints = Some(constraints);
        self
    }

    /// Replaces (or removes) the constraints.
    pub fn set_constraints(&mut self, constraints: Option<Constraints>) {
        self.constraints = constraints;
    }

    /// Copies `constraints` into the solver's own (reusing its storage),
    /// e.g. the constraints of a new time step.
    pub fn copy_constraints(&mut self, constraints: &Constraints) {
        match &mut self.constraints {
            Some(c) => c.clone_from(constraints),
            None => self.constraints = Some(constraints.clone()),
        }
    }

    /// The constraints, for refilling them in place between steps.
    pub fn constraints_mut(&mut self) -> Option<&mut Constraints> {
        self.constraints.as_mut()
    }

    /// The preconditioner.
    pub fn preconditioner(&self) -> &P {
        &self.precond
    }

    /// The preconditioner, mutably (e.g. to rebuild it from a checkpoint).
    pub fn preconditioner_mut(&mut self) -> &mut P {
        &mut self.precond
    }

    /// Arms a starting guess for the next solve only and returns its
    /// storage (length `n`, to be filled by the caller).
    pub fn arm_guess(&mut self, n: usize) -> &mut [f64] {
        self.guess.resize(n, 0.0);
        self.use_guess = true;
        &mut self.guess
    }

    /// Drops an armed guess that the next solve has not used.
    pub fn disarm_guess(&mut self) {
        self.use_guess = false;
    }
}

impl PcgSolver<AnyPreconditioner> {
    /// A PCG solver with the preconditioner, iteration limit and curvature
    /// policy of `options`.
    ///
    /// # Errors
    /// [`NonlinearError::Linear`] for an invalid preconditioner parameter.
    pub fn from_options(options: &PcgOptions) -> Result<Self, NonlinearError> {
        let precond = AnyPreconditioner::from_options(&options.preconditioner)?;
        Ok(Self::new(precond)
            .with_max_iter(options.max_iter)
            .with_negative_curvature(options.negative_curvature))
    }
}

impl<A, P> LinearSolver<A> for PcgSolver<P>
where
    A: LinearOperator + ?Sized,
    P: PreconditionerSetup<A>,
{
    fn setup(&mut self, jac: &A) -> Result<(), NonlinearError> {
        self.precond.setup(jac)?;
        self.set_up = true;
        Ok(())
    }

    fn solve(
        &mut self,
        jac: &A,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let n = jac.nrows();
        check_len("right-hand side", rhs, n)?;
        check_len("solution", x, n)?;
        if !(rtol >= 0.0) {
            return Err(invalid("rtol", format!("must be >= 0, got {rtol:?}")));
        }
        let guessed = std::mem::take(&mut self.use_guess);
        let initial_guess = if guessed {
            check_len("armed guess", &self.guess, n)?;
            x.copy_from_slice(&self.guess);
            InitialGuess::Given
        } else {
            InitialGuess::Zero
        };
        let params = CgParams {
            rtol,
            atol: 0.0,
            max_iter: self.max_iter,
            initial_guess,
            record_history: false,
            negative_curvature: self.negative_curvature,
            ..Default::default()
        };
        let info = match &self.constraints {
            Some(c) if !c.is_empty() => {
                self.z.resize(n, 0.0);
                self.shifted_rhs.resize(n, 0.0);
                self.z.fill(0.0);
                c.impose(&mut self.z);
                if self.z.iter().all(|&v| v == 0.0) {
                    // Homogeneous constraints (pins): A z = 0, no product needed.
                    self.shifted_rhs.copy_from_slice(rhs);
                } else {
                    jac.apply(&self.z, &mut self.shifted_rhs);
                    for i in 0..n {
                        self.shifted_rhs[i] += rhs[i];
                    }
                }
                // A given start needs no shift by z: filtered PCG imposes the
                // prescribed components on it.
                let info = filtered_pcg(
                    jac,
                    &self.precond,
                    &self.shifted_rhs,
                    x,
                    c,
                    &params,
                    &mut self.workspace,
                    None,
                )?;
                for i in 0..n {
                    x[i] -= self.z[i];
                }
                info
            }
            _ => pcg(
                jac,
                &self.precond,
                rhs,
                x,
                &params,
                &mut self.workspace,
                None,
            )?,
        };
        let stats = LinearSolveStats {
            iterations: info.iterations,
            residual_norm: info.residual_norm,
            relative_residual: info.true_relative_residual,
            converged: info.converged,
            truncated: info.truncated,
        };
        let set_up = std::mem::take(&mut self.set_up);
        if let Some(recorder) = &self.recorder.0 {
            let matrix = || jac.stored_matrix();
            let solve = RecordedSolve {
                matrix: &matrix,
                rhs,
                guess: guessed.then(|| &self.guess[..n]),
                solution: x,
                constraints: self.constraints.as_ref().filter(|c| !c.is_empty()),
                rtol,
                max_iter: self.max_iter,
                set_up,
                stats,
            };
            // A recorder that panicked once stays usable: its data are its own.
            recorder
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .record(&solve);
        }
        Ok(stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hookean_sparse::{IncompleteCholesky, Jacobi};

    #[test]
    fn pcg_solver_meets_the_requested_relative_residual() {
        let a = hookean_testkit::random::random_spd(200, 5, 1.05, 3);
        let b: Vec<f64> = (0..200).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
        for rtol in [0.5, 0.02, 1e-10] {
            let mut s = PcgSolver::new(Jacobi::new());
            s.setup(&a).unwrap();
            let mut x = vec![0.0; 200];
            let st = s.solve(&a, &b, &mut x, rtol).unwrap();
            assert!(st.converged);
            // The true residual, computed independently.
            let mut ax = vec![0.0; 200];
            a.apply(&x, &mut ax);
            let r: f64 = ax
                .iter()
                .zip(&b)
                .map(|(p, q)| (p - q) * (p - q))
                .sum::<f64>()
                .sqrt();
            let bn: f64 = b.iter().map(|q| q * q).sum::<f64>().sqrt();
            assert!(r <= 1.01 * rtol * bn, "rtol {rtol}: {}", r / bn);
        }
        let mut s = PcgSolver::new(IncompleteCholesky::new());
        s.setup(&a).unwrap();
        let mut x = vec![0.0; 200];
        let loose = s.solve(&a, &b, &mut x, 0.5).unwrap().iterations;
        let tight = s.solve(&a, &b, &mut x, 1e-10).unwrap().iterations;
        assert!(loose < tight);
        assert!(s.solve(&a, &b, &mut x, -1.0).is_err());
        assert!(s.solve(&a, &b[..10], &mut x, 0.1).is_err());
    }

    /// What a recorder keeps of each solve: the copies it makes.
    #[derive(Default)]
    struct Kept {
        solves: Vec<KeptSolve>,
    }

    struct KeptSolve {
        a: sprs::CsMat<f64>,
        rhs: Vec<f64>,
        guess: Option<Vec<f64>>,
        set_up: bool,
        iterations: usize,
        rtol: f64,
    }

    impl crate::SolveRecorder for Kept {
        fn record(&mut self, s: &RecordedSolve<'_>) {
            assert_eq!(s.constraints.map(Constraints::len), Some(1));
            self.solves.push(KeptSolve {
                a: s.matrix().unwrap(),
                rhs: s.rhs.to_vec(),
                guess: s.guess.map(<[f64]>::to_vec),
                set_up: s.set_up,
                iterations: s.stats.iterations,
                rtol: s.rtol,
            });
        }
    }

    /// The recorded solves, replayed by a fresh solver from the copies,
    /// take the same iterations to the same bits; without a recorder the
    /// solver computes the same.
    #[test]
    fn recorded_solves_replay_bit_for_bit() {
        use std::sync::{Arc, Mutex};
        let a = hookean_testkit::random::random_spd(60, 5, 1.05, 7);
        let b: Vec<f64> = (0..60).map(|i| ((i * 5) % 7) as f64 - 3.0).collect();
        let mut pins = Constraints::new(20);
        pins.pin(4, [0.0; 3]).unwrap();
        let kept = Arc::new(Mutex::new(Kept::default()));
        let mut s = PcgSolver::new(IncompleteCholesky::new()).with_constraints(pins.clone());
        let shared: SharedRecorder = kept.clone();
        s.set_recorder(Some(shared));
        let mut plain = PcgSolver::new(IncompleteCholesky::new()).with_constraints(pins.clone());
        let (mut x, mut y) = (vec![0.0; 60], vec![0.0; 60]);
        let mut first = Vec::new();
        for (k, solver) in [&mut s, &mut plain].into_iter().enumerate() {
            let x = if k == 0 { &mut x } else { &mut y };
            solver.setup(&a).unwrap();
            solver.solve(&a, &b, x, 1e-3).unwrap();
            first.push(x.clone());
            // The second solve: warm, on the preconditioner of the first.
            solver.arm_guess(60).fill(0.5);
            solver.solve(&a, &b, x, 1e-9).unwrap();
        }
        assert_eq!(x, y, "recording changes nothing");
        let kept = kept.lock().unwrap();
        assert_eq!(kept.solves.len(), 2);
        let (one, two) = (&kept.solves[0], &kept.solves[1]);
        assert!(one.set_up && !two.set_up, "set up before the first only");
        assert!(one.guess.is_none());
        assert_eq!(two.guess.as_deref(), Some(&[0.5; 60][..]));
        assert_eq!((one.rtol, two.rtol), (1e-3, 1e-9));
        let mut r = PcgSolver::new(IncompleteCholesky::new()).with_constraints(pins);
        let mut z = vec![0.0; 60];
        for (k, kept) in kept.solves.iter().enumerate() {
            if kept.set_up {
                r.setup(&kept.a).unwrap();
            }
            if let Some(g) = &kept.guess {
                r.arm_guess(60).copy_from_slice(g);
            }
            let st = r.solve(&kept.a, &kept.rhs, &mut z, kept.rtol).unwrap();
            assert_eq!(st.iterations, kept.iterations, "solve {k}");
            assert!(kept.iterations > 0);
            if k == 0 {
                assert_eq!(z, first[0]);
            }
        }
        assert_eq!(z, x);
    }
}
