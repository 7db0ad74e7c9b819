//! The implicit-explicit (IMEX) Euler scheme of Eberhardt, Etzmuss and
//! Hauth, "Implicit-explicit schemes for fast animation with particle
//! systems" (2000; \[EEH00\] in the filtering paper's section 7.2, cited in
//! the tutorial's section 2.6).
//!
//! The force is split into the linear part of the tutorial's eq. 50,
//! `f_lin(x, v) = K x + D v` with constant isotropic matrices `K`, `D`
//! ([`SecondOrderProblem::linearized_jacobians_iso`]), and the nonlinear
//! remainder `f - f_lin`. The linear part is integrated by implicit Euler,
//! the remainder by explicit Euler:
//!
//! ```text
//! M (v_{n+1} - v_n) = h [K x_{n+1} + D v_{n+1} + (f - f_lin)(x_n, v_n)],
//! x_{n+1} = x_n + h v_{n+1},
//! ```
//!
//! which, with `dv = v_{n+1} - v_n`, is one linear system with a constant
//! matrix:
//!
//! ```text
//! (M - h D - h^2 K) dv = h f(x_n, v_n) + h^2 K v_n.
//! ```
//!
//! `A = M - h D - h^2 K` changes only with `h` or the material
//! ([`SecondOrderProblem::material_revision`]): it is factored once
//! (sparse Cholesky of the `n x n` scalar matrix; isotropic blocks make the
//! three coordinates three solves with one factor), with the fully pinned
//! particles eliminated. A step with other constraints (contacts, sliding)
//! solves the same system by filtered PCG preconditioned with that factor.
//! For a linear force (`f = f_lin`) the scheme is implicit Euler, hence
//! unconditionally stable on the linear part; it is first order.

use std::cell::RefCell;

use hookean_problem::SecondOrderProblem;
use hookean_sparse::{
    CgParams, CgWorkspace, Constraints, DirectCholesky, IsoBlockMatrix, LinearOperator,
    Preconditioner, SparseError, filtered_pcg,
};

use crate::error::OdeError;
use crate::stats::Stats;

/// What the factorisation was built for.
#[derive(Debug, Clone, PartialEq)]
struct FactorKey {
    h: f64,
    revision: u64,
    /// The fully pinned particles eliminated from the factor.
    pinned: Vec<usize>,
}

/// The per-integrator state of the IMEX scheme: the linear part, its
/// matrix, the factor and scratch vectors (no allocation per step once
/// factored).
pub(crate) struct Imex {
    k: IsoBlockMatrix,
    d: IsoBlockMatrix,
    a: IsoBlockMatrix,
    key: Option<FactorKey>,
    factor: ComponentCholesky,
    pinned_now: Vec<usize>,
    rhs: Vec<f64>,
    kv: Vec<f64>,
    dv: Vec<f64>,
    workspace: CgWorkspace,
}

/// The Cholesky factor of the `n x n` scalar matrix of an isotropic block
/// matrix, applied to each of the three coordinates: a solver of the full
/// `3n` system, and its preconditioner for filtered PCG.
struct ComponentCholesky {
    chol: DirectCholesky,
    /// Fully pinned particles: their rows are identity in the factor and
    /// their components are copied through.
    pinned: Vec<bool>,
    scratch: RefCell<(Vec<f64>, Vec<f64>)>,
}

impl ComponentCholesky {
    /// `z = A^-1 r` coordinate by coordinate (pinned particles: `z = r`).
    fn solve(&self, r: &[f64], z: &mut [f64]) -> Result<(), SparseError> {
        let mut guard = self.scratch.borrow_mut();
        let (b, x) = &mut *guard;
        let n = b.len();
        for c in 0..3 {
            for i in 0..n {
                b[i] = r[3 * i + c];
            }
            self.chol.solve(b, x)?;
            for i in 0..n {
                z[3 * i + c] = x[i];
            }
        }
        Ok(())
    }
}

impl Preconditioner for ComponentCholesky {
    fn dim(&self) -> Option<usize> {
        Some(3 * self.pinned.len())
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) {
        // The factor is positive definite and `r` finite (PCG checks its
        // input), so the solve cannot fail; a failure would leave `z = r`.
        if self.solve(r, z).is_err() {
            z.copy_from_slice(r);
        }
    }
}

/// Why an IMEX step failed.
#[derive(Debug)]
pub(crate) enum ImexFailure {
    /// The problem has no linear part (eq. 50).
    NoLinearPart,
    /// The factorisation or the solve failed, or filtered PCG missed its
    /// tolerance ([`SparseError::NotConverged`]).
    Sparse(SparseError),
}

impl From<SparseError> for ImexFailure {
    fn from(e: SparseError) -> Self {
        ImexFailure::Sparse(e)
    }
}

impl Imex {
    /// Empty matrices on the problem's pattern; `None` if the problem has
    /// no linear part.
    pub fn new<P: SecondOrderProblem>(problem: &P) -> Option<Self> {
        let pattern = problem.jacobian_pattern();
        let mut k = IsoBlockMatrix::new(pattern.clone());
        let mut d = IsoBlockMatrix::new(pattern.clone());
        if !problem.linearized_jacobians_iso(&mut k, &mut d) {
            return None;
        }
        let n = pattern.n_blocks();
        Some(Self {
            k,
            d,
            a: IsoBlockMatrix::new(pattern),
            key: None,
            factor: ComponentCholesky {
                chol: DirectCholesky::new(),
                pinned: vec![false; n],
                scratch: RefCell::new((vec![0.0; n], vec![0.0; n])),
            },
            pinned_now: Vec::new(),
            rhs: vec![0.0; 3 * n],
            kv: vec![0.0; 3 * n],
            dv: vec![0.0; 3 * n],
            workspace: CgWorkspace::new(3 * n),
        })
    }

    /// Builds `A = M - h D - h^2 K` with the pinned particles' rows and
    /// columns replaced by the identity, and factors it.
    fn refactor<P: SecondOrderProblem>(
        &mut self,
        problem: &P,
        h: f64,
        stats: &mut Stats,
    ) -> Result<(), ImexFailure> {
        if !problem.linearized_jacobians_iso(&mut self.k, &mut self.d) {
            return Err(ImexFailure::NoLinearPart);
        }
        stats.num_jac_evals += 1;
        let n = self.factor.pinned.len();
        self.a.set_zero();
        self.a.add_scaled(-h, &self.d)?;
        self.a.add_scaled(-h * h, &self.k)?;
        let mass: Vec<f64> = problem.mass().iter().step_by(3).copied().collect();
        self.a.add_to_diagonal(&mass)?;
        self.factor.pinned.fill(false);
        for &p in &self.pinned_now {
            self.factor.pinned[p] = true;
        }
        // The scalar n x n matrix, both triangles, pinned rows/columns
        // replaced by the identity (factored rarely: it may allocate).
        let mut tri = sprs::TriMat::new((n, n));
        let pinned_at = &self.factor.pinned;
        self.a.for_each_stored(|i, j, a_ij| {
            let pinned = pinned_at[i] || pinned_at[j];
            let v = if i == j && pinned {
                1.0
            } else if pinned {
                0.0
            } else {
                a_ij
            };
            tri.add_triplet(i, j, v);
            if i != j {
                tri.add_triplet(j, i, v);
            }
        });
        self.factor.chol.factor_csr(&tri.to_csr())?;
        stats.num_lin_solv_setups += 1;
        self.key = Some(FactorKey {
            h,
            revision: problem.material_revision(),
            pinned: self.pinned_now.clone(),
        });
        Ok(())
    }

    /// What the next step reuses, for a checkpoint: the key its factor of
    /// `A = M - h D - h^2 K` was built for (`[1, h, revision, pinned
    /// particles...]`, or `[0]` before the first factorisation). The
    /// matrices and the factor are not saved: `K`, `D` are the problem's
    /// constants at its material revision, so [`restored`](Self::restored)
    /// rebuilds `A` and its factor bit for bit from the key. The right-hand
    /// side, `K v`, `dv` and the PCG work are written before they are read.
    pub fn carried(&self) -> Vec<f64> {
        match &self.key {
            None => vec![0.0],
            Some(k) => {
                let mut c = vec![1.0, k.h, k.revision as f64];
                c.extend(k.pinned.iter().map(|&p| p as f64));
                c
            }
        }
    }

    /// The scheme of `problem` (restored to the checkpoint's state) with
    /// the factor [`carried`](Self::carried) describes.
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] for a malformed `carried` or a problem
    /// without a linear part; the factorisation's errors.
    pub fn restored<P: SecondOrderProblem>(problem: &P, carried: &[f64]) -> Result<Self, OdeError> {
        let misfit = |reason: &str| OdeError::Checkpoint {
            reason: format!("entry `sys.imex` {reason}"),
        };
        let mut imex = Self::new(problem)
            .ok_or_else(|| misfit("is the IMEX scheme's, this problem has no linear part"))?;
        let n = imex.factor.pinned.len();
        let count = |v: f64| v >= 0.0 && v.fract() == 0.0 && v < 9.007_199_254_740_992e15;
        match carried {
            [0.0] => {}
            &[1.0, h, revision, ref pinned @ ..] => {
                let sorted = pinned.windows(2).all(|w| w[0] < w[1]);
                if !(h > 0.0 && h.is_finite() && count(revision) && sorted)
                    || pinned.iter().any(|&p| !(count(p) && (p as usize) < n))
                {
                    return Err(misfit("is malformed"));
                }
                imex.pinned_now = pinned.iter().map(|&p| p as usize).collect();
                imex.refactor(problem, h, &mut Stats::default())
                    .map_err(|e| match e {
                        ImexFailure::NoLinearPart => {
                            misfit("is the IMEX scheme's, this problem has no linear part")
                        }
                        ImexFailure::Sparse(e) => OdeError::Sparse(e),
                    })?;
                if let Some(k) = &mut imex.key {
                    k.revision = revision as u64;
                }
            }
            _ => return Err(misfit("is malformed")),
        }
        Ok(imex)
    }

    /// One IMEX step from `(x, v)` at `t` (positions and velocities in
    /// place; `constraints` are the step's, their values the prescribed
    /// velocity changes). Returns the PCG iterations (0 for a direct solve).
    #[allow(clippy::too_many_arguments)]
    pub fn step<P: SecondOrderProblem>(
        &mut self,
        problem: &P,
        constraints: &Constraints,
        t: f64,
        h: f64,
        x: &mut [f64],
        v: &mut [f64],
        force: &mut [f64],
        stats: &mut Stats,
    ) -> Result<usize, ImexFailure> {
        self.pinned_now.clear();
        let mut partial = false;
        for (p, c) in constraints.counts() {
            if c == 3 {
                self.pinned_now.push(p);
            } else if c > 0 {
                partial = true;
            }
        }
        self.pinned_now.sort_unstable();
        let stale = match &self.key {
            None => true,
            Some(k) => {
                k.h != h || k.revision != problem.material_revision() || k.pinned != self.pinned_now
            }
        };
        if stale {
            self.refactor(problem, h, stats)?;
        }
        // rhs = h f(x_n, v_n) + h^2 K v_n, constrained directions removed.
        problem.force(t, x, v, force);
        stats.num_rhs_evals += 1;
        self.k.apply(v, &mut self.kv);
        for ((r, f), kv) in self.rhs.iter_mut().zip(force.iter()).zip(&self.kv) {
            *r = h * f + h * h * kv;
        }
        let iterations = if partial {
            // Contacts or sliding: the constant matrix, filtered PCG
            // preconditioned by its factor.
            constraints.project(&mut self.rhs);
            self.dv.fill(0.0);
            let info = filtered_pcg(
                &self.a,
                &self.factor,
                &self.rhs,
                &mut self.dv,
                constraints,
                &CgParams {
                    rtol: 1e-10,
                    ..CgParams::default()
                },
                &mut self.workspace,
                None,
            )?;
            stats.num_lin_iters += info.iterations;
            info.ensure_converged()?.iterations
        } else {
            for &p in &self.pinned_now {
                self.rhs[3 * p..3 * p + 3].fill(0.0);
            }
            self.factor.solve(&self.rhs, &mut self.dv)?;
            0
        };
        for (vi, d) in v.iter_mut().zip(&self.dv) {
            *vi += d;
        }
        if !constraints.is_empty() {
            constraints.impose(v);
        }
        for (xi, vi) in x.iter_mut().zip(v.iter()) {
            *xi += h * vi;
        }
        Ok(iterations)
    }
}
