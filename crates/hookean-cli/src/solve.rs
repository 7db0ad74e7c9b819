//! `hookean solve`: PCG with every preconditioner, and the direct baseline,
//! on a Matrix Market system.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use hookean_sparse::{
    AmgSmoother, AmgStats, AnyPreconditioner, CgParams, CgProgress, CgWorkspace, DirectCholesky,
    LinearOperator, PrecondKind, PreconditionerOptions, PreconditionerSetup, ReadOptions,
    SparseError, SymBlockMatrix, detect_block_size, pcg, read_matrix_market_file_with,
    vecops::norm2,
};
use serde::Serialize;

use crate::CliError;
use crate::amg_args::{AmgArgs, read_columns, read_rigid_body_modes};

#[derive(Debug, Args)]
pub struct SolveArgs {
    #[command(flatten)]
    system: SystemArgs,
    #[command(flatten)]
    solver: SolverArgs,
}

/// The files and flags naming a system, of `hookean solve` and `hookean tune`.
#[derive(Debug, Args)]
pub struct SystemArgs {
    /// The matrix A (Matrix Market, coordinate or array, real, general or symmetric).
    pub matrix: PathBuf,
    /// The right-hand side b (Matrix Market, one column); default b = A * ones.
    #[arg(long)]
    pub rhs: Option<PathBuf>,
    /// Matrix storage for PCG: block (symmetric 3x3 blocks, needs n divisible by 3
    /// and a symmetric matrix), csr, or auto (block when the nodes have 3 unknowns
    /// by --block-size, --nullspace, --coordinates or the pattern and the matrix
    /// allows it; else csr, so a scalar matrix keeps scalar storage whatever its size).
    #[arg(long, default_value = "auto")]
    pub format: String,
    /// Unknowns per node for `--precond amg` and `block-jacobi` on csr storage: 1,
    /// 2 (e.g. 2D elasticity) or 3 (block storage always has 3). Default: read off the
    /// first vector of `--nullspace` (a translation, non-zero at every d-th
    /// entry), or the columns of `--coordinates`, else detected from the
    /// pattern (2 or 3 when every row of a node couples to the same nodes for
    /// exactly one of them), else 1. The JSON's `block_size_source` says which.
    #[arg(long)]
    pub block_size: Option<usize>,
    /// The near-nullspace of `--precond amg`: a Matrix Market file whose
    /// columns are the vectors (e.g. the rigid-body modes: 3 on nodes of 2
    /// unknowns, 6 on nodes of 3; as many as the unknowns per node, or one
    /// for a scalar matrix). Default: the translations (the constant).
    #[arg(long, conflicts_with = "coordinates")]
    pub nullspace: Option<PathBuf>,
    /// Node coordinates (Matrix Market, n x d, d = 2 or 3, one row per node,
    /// d unknowns per node): `amg` takes their rigid-body modes (3 in 2D, 6 in
    /// 3D) as its near-nullspace.
    #[arg(long)]
    pub coordinates: Option<PathBuf>,
}

/// The most runs `--repeat` asks for.
const MAX_REPEAT: usize = 1000;
/// The largest `--max-iter`.
const MAX_ITER: usize = 10_000_000;

/// The solver options `hookean solve` and `hookean bench-precond` share.
#[derive(Debug, Clone, Args)]
pub struct SolverArgs {
    /// none, jacobi, block-jacobi, ssor, ic0, mic0 (block storage only), amg (smoothed-aggregation
    /// multigrid: 3x3 blocks on block storage, scalar on csr), direct (faer sparse Cholesky), all,
    /// or a comma-separated list of these (run in that order, in one process).
    #[arg(long, default_value = "all")]
    pub precond: String,
    /// SSOR relaxation, in (0, 2).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub omega: f64,
    /// MIC(0) relaxation (the scene key solver.mic_omega), in [0, 1].
    #[arg(long, default_value_t = PrecondKind::MIC_OMEGA, allow_negative_numbers = true)]
    pub mic_omega: f64,
    /// Relative residual tolerance |r| / |b| of PCG, in [0, 1).
    #[arg(long, default_value_t = 1e-8, allow_negative_numbers = true)]
    pub rtol: f64,
    /// PCG iteration limit, 0 to 10^7 (default 2 n).
    #[arg(long)]
    pub max_iter: Option<usize>,
    /// Run each solver this many times (1 to 1000) and report the best times.
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    #[command(flatten)]
    pub amg: AmgArgs,
    /// Refuse a matrix, system or direct factor that would need more memory than this (GiB),
    /// in (0, the machine's memory].
    #[arg(
        long,
        value_name = "GIB",
        default_value_t = 8.0,
        allow_negative_numbers = true
    )]
    pub max_memory: f64,
    /// Do not estimate the extreme eigenvalues of M^-1 A from PCG's coefficients (the JSON's
    /// `lambda_min`, `lambda_max`, `condition`; bench.csv's columns of those names).
    #[arg(long)]
    pub no_condition_estimate: bool,
}

/// The flags of [`SolverArgs`] resolved once: every solver to run with its
/// settings, PCG's parameters, the repetitions and the memory cap.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The solvers, in the order given.
    pub solvers: Vec<Solver>,
    /// PCG's tolerance and iteration limit.
    pub params: CgParams,
    /// Runs of each solver (`--repeat`); the best times are reported.
    pub repeat: usize,
    /// `--max-memory` in bytes, lowered to the process's limit.
    pub cap: u64,
    /// MIC(0) came with `all`: it is skipped on CSR storage (where it does
    /// not exist) instead of failing.
    pub mic0_from_all: bool,
}

impl SolverArgs {
    /// Checks the flags once and resolves them into the [`Plan`]: each PCG
    /// solver carries its preconditioner with the multigrid's options (the
    /// block size and near-nullspace are the system's, set by
    /// [`run_solver`]).
    pub fn resolve(&self) -> Result<Plan, CliError> {
        let (repeat, omega, rtol) = (self.repeat, self.omega, self.rtol);
        if !(1..=MAX_REPEAT).contains(&repeat) {
            return Err(CliError::Input(format!(
                "--repeat must lie in 1 to {MAX_REPEAT}, got {repeat}"
            )));
        }
        // The scene key solver.omega's range (hookean::range owns it).
        hookean::range::SSOR_OMEGA
            .check(omega)
            .map_err(|m| CliError::Input(format!("--omega {m}")))?;
        hookean::range::MIC_OMEGA
            .check(self.mic_omega)
            .map_err(|m| CliError::Input(format!("--mic-omega {m}")))?;
        let params = CgParams {
            estimate_condition: !self.no_condition_estimate,
            ..cg_params(rtol, self.max_iter)?
        };
        let amg = self.amg.options(1, Vec::new())?;
        let cap = crate::memory::cap_bytes(self.max_memory)?;
        let mut mic0_from_all = false;
        let mut solvers = Vec::new();
        for name in self.precond.split(',').map(str::trim) {
            mic0_from_all |= name == "all";
            parse_solver(name, omega, self.mic_omega, &mut solvers)?;
        }
        for solver in &mut solvers {
            if let Solver::Pcg(options) = solver {
                options.amg.clone_from(&amg);
            }
        }
        Ok(Plan {
            solvers,
            params,
            repeat,
            cap,
            mic0_from_all,
        })
    }
}

/// PCG's parameters from `--rtol` and `--max-iter`, checked.
pub fn cg_params(rtol: f64, max_iter: Option<usize>) -> Result<CgParams, CliError> {
    if let Some(m) = max_iter.filter(|&m| m > MAX_ITER) {
        return Err(CliError::Input(format!(
            "--max-iter must lie in 0 to {MAX_ITER}, got {m}"
        )));
    }
    // 0 is allowed here: "cannot converge" is a solve's failure to report.
    hookean::range::Range::closed_open(0.0, 1.0)
        .check(rtol)
        .map_err(|m| CliError::Input(format!("--rtol {m}")))?;
    Ok(CgParams {
        rtol,
        max_iter,
        ..Default::default()
    })
}

/// One JSON line of output.
#[derive(Debug, Serialize)]
pub struct SolveRecord {
    pub matrix: String,
    pub solver: &'static str,
    pub precond: String,
    pub format: &'static str,
    pub rows: usize,
    pub nnz: usize,
    pub setup_s: f64,
    pub solve_s: f64,
    pub iterations: usize,
    /// The true `|b - A x| / |b|` of the solution, on the matrix as read.
    pub rel_residual: f64,
    /// PCG's recursively updated `|r| / |b|` at its stop (absent for the
    /// direct solver): it drifts from `rel_residual` by round-off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recursive_rel_residual: Option<f64>,
    /// Whether the true residual met the tolerance.
    pub converged: bool,
    /// The smallest eigenvalue of M^-1 A that PCG's Lanczos matrix gives
    /// ([`hookean_sparse::ConditionEstimate`]; not for the direct solver,
    /// or with `--no-condition-estimate`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda_min: Option<f64>,
    /// The largest, likewise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lambda_max: Option<f64>,
    /// `lambda_max / lambda_min`: the condition estimate of M^-1 A.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub condition: Option<f64>,
    /// The unknowns per node of the storage (3 on block storage; the
    /// multigrid's on csr), when the caller read the matrix.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub block_size: Option<usize>,
    /// Where [`block_size`](Self::block_size) came from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub block_size_source: Option<BlockSizeSource>,
    /// The multigrid hierarchy, for `amg`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amg: Option<AmgRecord>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// `(seconds since the set-up started, |r| / |b|)` of the best run when
    /// traced (`hookean bench`'s residual-against-time plots): the start of
    /// the solve, then every iteration (PCG's recursive residual), or the
    /// end of the solve for the direct solver.
    #[serde(skip)]
    pub trace: Vec<(f64, f64)>,
    /// Heap bytes allocated by the set-up and still held after it (the
    /// `hookean` binary counts them): what the preconditioner (or the
    /// factor) keeps.
    #[serde(skip)]
    pub setup_bytes: Option<u64>,
    /// PCG stopped at [`RunOptions::time_limit`] before the tolerance.
    #[serde(skip)]
    pub timed_out: bool,
}

/// The statistics of an AMG hierarchy in `hookean solve`'s JSON.
#[derive(Debug, Serialize)]
pub struct AmgRecord {
    pub levels: usize,
    /// Scalar unknowns per level, finest first.
    pub rows: Vec<usize>,
    /// Scalar nonzeros per level.
    pub nonzeros: Vec<usize>,
    pub operator_complexity: f64,
    pub grid_complexity: f64,
    /// Whether the coarsest level is solved directly (else only smoothed).
    pub coarsest_direct: bool,
}

impl From<&AmgStats> for AmgRecord {
    fn from(s: &AmgStats) -> Self {
        Self {
            levels: s.levels.len(),
            rows: s.levels.iter().map(|l| l.rows).collect(),
            nonzeros: s.levels.iter().map(|l| l.nonzeros).collect(),
            operator_complexity: s.operator_complexity,
            grid_complexity: s.grid_complexity,
            coarsest_direct: s.coarsest_direct,
        }
    }
}

/// One solver of the comparison: PCG with a preconditioner, or the direct
/// sparse Cholesky baseline.
#[derive(Debug, Clone)]
pub enum Solver {
    /// PCG with this preconditioner and its settings.
    Pcg(PreconditionerOptions),
    /// faer's sparse Cholesky.
    Direct,
}

impl Solver {
    /// The name in the JSON's `precond` field.
    pub fn name(&self) -> String {
        match self {
            Solver::Pcg(options) => options.to_string(),
            Solver::Direct => "direct".into(),
        }
    }

    /// Whether this is PCG with the multigrid.
    pub fn is_amg(&self) -> bool {
        matches!(self, Solver::Pcg(o) if o.kind == PrecondKind::Amg)
    }
}

/// Appends the solvers of one name of `--precond`: `all` (every
/// preconditioner, then `direct`), `direct`, or a preconditioner (SSOR with
/// relaxation `omega`, MIC(0) with `mic_omega`).
fn parse_solver(
    name: &str,
    omega: f64,
    mic_omega: f64,
    out: &mut Vec<Solver>,
) -> Result<(), CliError> {
    let pcg = |kind: PrecondKind| Solver::Pcg(kind.into());
    if name == "all" {
        out.extend(PrecondKind::all(omega).into_iter().map(pcg));
        out.push(pcg(PrecondKind::Mic0 { omega: mic_omega }));
        out.push(Solver::Direct);
    } else if name == "direct" {
        out.push(Solver::Direct);
    } else {
        let kind: PrecondKind = name.parse()?;
        out.push(pcg(match kind {
            PrecondKind::Ssor { .. } => PrecondKind::Ssor { omega },
            PrecondKind::Mic0 { .. } => PrecondKind::Mic0 { omega: mic_omega },
            other => other,
        }));
    }
    Ok(())
}

/// The matrix in the storage PCG runs on (hookean-sparse owns the rule).
pub use hookean_sparse::PcgMatrix as Matrix;

/// Runs one solver on `A x = b` (`matrix` in PCG's storage, `original` the
/// same matrix as CSR, for the residual and the direct solver), the best
/// times of `repeat` runs, as a record with an empty `matrix` name and
/// zero `rows` / `nnz` for the caller to fill in. Shared by `hookean solve`,
/// `hookean bench-precond` and `hookean bench`; only the last traces
/// (`run.trace`), so the others' timings carry no per-iteration callback.
pub fn run_solver(
    solver: &Solver,
    matrix: &Matrix,
    original: &sprs::CsMat<f64>,
    b: &[f64],
    plan: &Plan,
    run: &RunOptions,
) -> SolveRecord {
    let repeat = plan.repeat;
    match solver {
        Solver::Pcg(options) => {
            let (block_size, format) = match matrix {
                Matrix::Block(_) => (3, "sym-block-3x3"),
                Matrix::Csr { block_size, .. } => (*block_size, "csr"),
            };
            // The options completed with the system's unknowns per node
            // (the multigrid's and block Jacobi's nodes) and the multigrid's
            // near-nullspace.
            let mut precond = options.clone();
            precond.amg.block_size = block_size;
            if precond.kind == PrecondKind::Amg {
                precond.amg.near_nullspace.clone_from(&run.near_nullspace);
            }
            let pcg = PcgRun {
                original,
                b,
                precond: &precond,
                params: &plan.params,
                repeat,
                format,
                trace: run.trace,
                time_limit: run.time_limit,
            };
            match matrix {
                Matrix::Block(m) => pcg.run(m, m),
                Matrix::Csr {
                    a,
                    product: Some(s),
                    ..
                } => pcg.run(&**s, a),
                // No symmetric product: `a` is not symmetric (or not finite),
                // and PCG, like the direct solver, would solve another system.
                Matrix::Csr { a, .. } => match hookean_sparse::check_csr_symmetric(a) {
                    Ok(()) => pcg.run(a, a),
                    Err(e) => {
                        let mut record = empty_record("hookean-pcg", solver.name(), format);
                        record.error = Some(format!("{e} (PCG needs a symmetric matrix)"));
                        record
                    }
                },
            }
        }
        Solver::Direct => {
            // The factor gets what the cap leaves beside the matrix's copies
            // (CSR, block storage, the direct solver's own: about 40 bytes a nonzero).
            let budget = plan.cap.saturating_sub(40 * original.nnz() as u64);
            run_direct(original, b, plan.params.rtol, repeat, budget, run.trace)
        }
    }
}

/// Where a system's unknowns per node came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BlockSizeSource {
    /// `--block-size`.
    Flag,
    /// The near-nullspace file's first vector ([`hookean_sparse::nullspace_block_size`]).
    Nullspace,
    /// The dimension of `--coordinates`.
    Coordinates,
    /// The matrix's pattern ([`detect_block_size`]).
    Detected,
    /// Nothing said (or `--format block` over another size): 1, or 3 on
    /// block storage.
    Default,
}

impl BlockSizeSource {
    /// The name in the JSON and in `hookean bench`'s table.
    pub fn name(self) -> &'static str {
        match self {
            Self::Flag => "flag",
            Self::Nullspace => "nullspace",
            Self::Coordinates => "coordinates",
            Self::Detected => "detected",
            Self::Default => "default",
        }
    }

    /// Where the block size came from, in the user's words.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Flag => "set by --block-size",
            Self::Nullspace => "read off the first vector's zeros",
            Self::Coordinates => "the columns of --coordinates",
            Self::Detected => "detected from the matrix's pattern",
            Self::Default => "the default: 1, or 3 on block storage; --block-size sets it",
        }
    }
}

/// A system read from Matrix Market files, scaled and in PCG's storage.
pub struct System {
    /// `A`, scaled by a power of two to a largest entry in [1, 2).
    pub a: sprs::CsMat<f64>,
    /// `b` (from its file, or `A * ones`), scaled the same way.
    pub b: Vec<f64>,
    /// `A` in the storage PCG runs on.
    pub matrix: Matrix,
    /// The unknowns per node of `matrix` (3 on block storage).
    pub block_size: usize,
    /// Where `block_size` came from.
    pub block_size_source: BlockSizeSource,
}

/// Reads `A` from `matrix` and `b` from `rhs` (default `A * ones`) within
/// `cap` bytes, and stores `A` as `format` (`block`, `csr` or `auto`) with
/// `block_size` unknowns per node for the multigrid and block Jacobi on
/// CSR: the caller's `(size, source)`, else [`detect_block_size`] of A's
/// pattern. `auto` takes block storage when that size is 3 and A allows
/// it, else CSR ([`Matrix::auto`]).
///
/// Powers of two scale A and b exactly to largest entries near 1, so a
/// system of tiny or huge numbers (entries of 1e-308) solves as its scaled
/// copy does; every reported number (iterations, relative residual) is the
/// same for both.
pub fn load_system(
    matrix: &std::path::Path,
    rhs: Option<&std::path::Path>,
    format: &str,
    block_size: Option<(usize, BlockSizeSource)>,
    cap: u64,
) -> Result<System, CliError> {
    let opts = ReadOptions {
        max_bytes: cap,
        ..ReadOptions::default()
    };
    let a = read_matrix_market_file_with(matrix, &opts)?.into_csr();
    let (rows, cols) = a.shape();
    if rows != cols {
        return Err(CliError::Input(format!(
            "{}: matrix is not square ({rows} x {cols})",
            matrix.display()
        )));
    }
    if rows == 0 {
        return Err(CliError::Input(format!(
            "{}: the matrix is empty (0 x 0): there is nothing to solve",
            matrix.display()
        )));
    }
    let b = match rhs {
        Some(path) => {
            let b = read_matrix_market_file_with(path, &opts)?
                .into_vector()
                .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
            if b.len() != rows {
                return Err(CliError::Input(format!(
                    "{}: right-hand side has {} entries, the matrix has {rows} rows",
                    path.display(),
                    b.len()
                )));
            }
            b
        }
        None => {
            let mut b = vec![0.0; rows];
            a.apply(&vec![1.0; rows], &mut b);
            b
        }
    };
    let (a, b) = (scale_to_unit(a), {
        let mut b = b;
        let e = unit_exponent(b.iter().copied());
        b.iter_mut().for_each(|v| *v = times_pow2(*v, -e));
        b
    });
    let (block_size, source) = block_size.unwrap_or_else(|| match detect_block_size(&a) {
        1 => (1, BlockSizeSource::Default),
        d => (d, BlockSizeSource::Detected),
    });
    if !(1..=3).contains(&block_size) {
        return Err(CliError::Input(format!(
            "--block-size must be 1, 2 or 3, got {block_size:?}"
        )));
    }
    let matrix = match format {
        "csr" => Matrix::csr(a.clone(), block_size),
        "block" => Matrix::Block(SymBlockMatrix::from_csr(&a).map_err(|e| {
            CliError::Input(format!(
                "{}: cannot use block storage: {e}",
                matrix.display()
            ))
        })?),
        "auto" => Matrix::auto(a.clone(), block_size),
        other => {
            return Err(CliError::Input(format!(
                "unknown --format '{other}' (expected block, csr or auto)"
            )));
        }
    };
    let (block_size, block_size_source) = match matrix {
        // Block storage has 3 whatever was asked for.
        Matrix::Block(_) if block_size != 3 => (3, BlockSizeSource::Default),
        Matrix::Block(_) => (3, source),
        Matrix::Csr { block_size, .. } => (block_size, source),
    };
    Ok(System {
        a,
        b,
        matrix,
        block_size,
        block_size_source,
    })
}

/// Reads the system of `paths` within `cap` bytes ([`load_system`]) and
/// the multigrid's near-nullspace (`--nullspace`, or the rigid-body modes
/// of `--coordinates`; empty for neither), which also sets the unknowns per
/// node unless `--block-size` does; a near-nullspace of the wrong shape is
/// bad input naming its flag.
pub fn read_system(paths: &SystemArgs, cap: u64) -> Result<(System, Vec<Vec<f64>>), CliError> {
    let input = |flag: &str, path: &std::path::Path, e: String| {
        CliError::Input(format!("--{flag} {}: {e}", path.display()))
    };
    let (near_nullspace, implied) = match (paths.nullspace.as_deref(), paths.coordinates.as_deref())
    {
        (Some(p), _) => {
            let v = read_columns(p, cap).map_err(|e| input("nullspace", p, e))?;
            let d =
                hookean_sparse::nullspace_block_size(&v).map(|d| (d, BlockSizeSource::Nullspace));
            (v, d)
        }
        (None, Some(p)) => {
            let v = read_rigid_body_modes(p, cap).map_err(|e| input("coordinates", p, e))?;
            let d = if v.len() == 3 { 2 } else { 3 };
            (v, Some((d, BlockSizeSource::Coordinates)))
        }
        (None, None) => (Vec::new(), None),
    };
    let block_size = paths
        .block_size
        .map(|d| (d, BlockSizeSource::Flag))
        .or(implied);
    let System {
        a,
        b,
        matrix,
        block_size,
        block_size_source,
    } = load_system(
        &paths.matrix,
        paths.rhs.as_deref(),
        &paths.format,
        block_size,
        cap,
    )?;
    let rows = a.rows();
    let source = match (paths.nullspace.as_deref(), paths.coordinates.as_deref()) {
        (Some(p), _) => Some(("nullspace", p)),
        (None, Some(p)) => Some(("coordinates", p)),
        (None, None) => None,
    };
    let short = near_nullspace.iter().find(|v| v.len() != rows);
    if let (Some(v), Some((flag, path))) = (short, source) {
        return Err(input(
            flag,
            path,
            format!(
                "the near-nullspace vectors have {} entries, the matrix has {rows} rows",
                v.len()
            ),
        ));
    }
    // The shapes the multigrid takes (hookean-sparse owns them), checked
    // for any --precond: a file of the wrong shape is bad input, not a
    // failed set-up (exit 1) or a file ignored.
    if let Some(path) = paths.nullspace.as_deref() {
        let k = near_nullspace.len();
        let zero = near_nullspace
            .iter()
            .position(|v| v.iter().all(|&x| x == 0.0));
        let problem = if k == 0 {
            Some("no vectors (0 columns)".to_string())
        } else if let Some(j) = zero {
            Some(format!("column {} is zero", j + 1))
        } else if !hookean_sparse::amg_takes_near_nullspace(block_size, k) {
            Some(format!(
                "{k} vectors on nodes of {block_size} unknown{} ({})",
                if block_size == 1 { "" } else { "s" },
                block_size_source.describe()
            ))
        } else {
            None
        };
        if let Some(problem) = problem {
            return Err(input(
                "nullspace",
                path,
                format!(
                    "{problem}; expected a {rows} x k array of k near-nullspace vectors: {}",
                    hookean_sparse::AMG_NEAR_NULLSPACE_SHAPES
                ),
            ));
        }
    }
    Ok((
        System {
            a,
            b,
            matrix,
            block_size,
            block_size_source,
        },
        near_nullspace,
    ))
}

pub fn run(args: &SolveArgs) -> Result<(), CliError> {
    let plan = args.solver.resolve()?;
    let (
        System {
            a,
            b,
            matrix,
            block_size,
            block_size_source,
        },
        near_nullspace,
    ) = read_system(&args.system, plan.cap)?;
    let rows = a.rows();
    // MIC(0) exists for block storage only: "all" skips it on CSR.
    let solvers = plan.solvers.iter().filter(|s| {
        !(plan.mic0_from_all
            && matches!(matrix, Matrix::Csr { .. })
            && matches!(s, Solver::Pcg(o) if matches!(o.kind, PrecondKind::Mic0 { .. })))
    });
    let name = args.system.matrix.display().to_string();
    let mut failed = false;
    for solver in solvers {
        let record = run_solver(
            solver,
            &matrix,
            &a,
            &b,
            &plan,
            &RunOptions {
                near_nullspace: near_nullspace.clone(),
                ..Default::default()
            },
        );
        let record = SolveRecord {
            matrix: name.clone(),
            rows,
            nnz: a.nnz(),
            block_size: Some(block_size),
            block_size_source: Some(block_size_source),
            ..record
        };
        // A failed solver, or one that did not reach the tolerance, fails the command.
        failed |= record.error.is_some() || !record.converged;
        crate::outln!("{}", crate::to_json(&record, false)?)?;
    }
    if failed {
        return Err(CliError::SolverFailed);
    }
    Ok(())
}

/// The exponent `e` with `2^e <= max |v| < 2^(e+1)` (0 for no non-zero entry).
fn unit_exponent(values: impl Iterator<Item = f64>) -> i32 {
    let m = values.fold(0.0_f64, |m, v| m.max(v.abs()));
    if m > 0.0 && m.is_finite() {
        m.log2().floor() as i32
    } else {
        0
    }
}

/// `v * 2^e`, exact unless the result leaves the normal range, in steps
/// that stay representable (2^e alone may not be).
fn times_pow2(v: f64, e: i32) -> f64 {
    let mut v = v;
    let mut e = e;
    while e != 0 {
        let k = e.clamp(-1000, 1000);
        v *= 2f64.powi(k);
        e -= k;
    }
    v
}

/// `a` scaled by a power of two to a largest entry in [1, 2).
fn scale_to_unit(mut a: sprs::CsMat<f64>) -> sprs::CsMat<f64> {
    let e = unit_exponent(a.data().iter().copied());
    if e != 0 {
        a.data_mut()
            .iter_mut()
            .for_each(|v| *v = times_pow2(*v, -e));
    }
    a
}

fn relative_residual(a: &sprs::CsMat<f64>, x: &[f64], b: &[f64]) -> f64 {
    let mut ax = vec![0.0; b.len()];
    a.apply(x, &mut ax);
    let r: Vec<f64> = ax.iter().zip(b).map(|(p, q)| q - p).collect();
    let bn = norm2(b);
    if bn > 0.0 { norm2(&r) / bn } else { norm2(&r) }
}

/// A record of no run yet: the caller fills in what it measured.
pub(crate) fn empty_record(
    solver: &'static str,
    precond: String,
    format: &'static str,
) -> SolveRecord {
    SolveRecord {
        matrix: String::new(),
        solver,
        precond,
        format,
        rows: 0,
        nnz: 0,
        setup_s: 0.0,
        solve_s: 0.0,
        iterations: 0,
        rel_residual: f64::NAN,
        recursive_rel_residual: None,
        converged: false,
        lambda_min: None,
        lambda_max: None,
        condition: None,
        block_size: None,
        block_size_source: None,
        amg: None,
        error: None,
        trace: Vec::new(),
        setup_bytes: None,
        timed_out: false,
    }
}

/// What [`run_solver`] does besides solving.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Record [`SolveRecord::trace`] (a callback and a clock read per iteration).
    pub trace: bool,
    /// The multigrid's near-nullspace vectors (empty: its default).
    pub near_nullspace: Vec<Vec<f64>>,
    /// Stop PCG once this many seconds have passed since its set-up
    /// started ([`SolveRecord::timed_out`]; a clock read per iteration):
    /// `hookean tune` abandons a candidate that cannot win.
    pub time_limit: Option<f64>,
}

/// The heap bytes live now, where the binary counts them.
fn live_heap_bytes() -> Option<u64> {
    crate::alloc::live_bytes().map(|b| b as u64)
}

/// The heap growth from `before` to now: what was allocated and kept.
fn growth_since(before: Option<u64>) -> Option<u64> {
    Some(live_heap_bytes()?.saturating_sub(before?))
}

/// One PCG solver of the comparison, run `repeat` times.
struct PcgRun<'a> {
    original: &'a sprs::CsMat<f64>,
    b: &'a [f64],
    precond: &'a PreconditionerOptions,
    params: &'a CgParams,
    repeat: usize,
    format: &'static str,
    trace: bool,
    time_limit: Option<f64>,
}

impl PcgRun<'_> {
    /// The message of a failed solve: a multigrid preconditioner that is
    /// not positive definite (on an SPD matrix) means its smoother
    /// diverges, and the message says so, naming the weight.
    fn explain(&self, e: &SparseError) -> String {
        match e {
            SparseError::PreconditionerNotPositiveDefinite { iteration, .. }
                if self.precond.kind == PrecondKind::Amg
                    && self.precond.amg.smoother != AmgSmoother::BlockJacobi =>
            {
                format!(
                    "the multigrid's smoother (--amg-smoother {}) diverges: the V-cycle is not \
                     positive definite (found at CG iteration {iteration}); try --amg-smoother \
                     block-jacobi",
                    match self.precond.amg.smoother {
                        AmgSmoother::SymmetricGaussSeidel => "gauss-seidel",
                        _ => "ic0",
                    }
                )
            }
            SparseError::PreconditionerNotPositiveDefinite { iteration, .. }
                if self.precond.kind == PrecondKind::Amg =>
            {
                format!(
                    "the multigrid's smoother diverges: with --amg-jacobi-weight {} its damped \
                     Jacobi weight times the spectral radius of D^-1 A exceeds 2 on some level \
                     (the radius estimate of --amg-power-iterations {} is low), so the V-cycle \
                     is not positive definite (found at CG iteration {iteration}); lower \
                     --amg-jacobi-weight or raise --amg-power-iterations",
                    self.precond.amg.jacobi_weight, self.precond.amg.power_iterations
                )
            }
            _ => e.to_string(),
        }
    }

    /// PCG on the operator `m` with a preconditioner built from `source`
    /// (the same matrix in the storage the preconditioners take).
    fn run<M, S>(&self, m: &M, source: &S) -> SolveRecord
    where
        M: LinearOperator,
        AnyPreconditioner: PreconditionerSetup<S>,
    {
        let (b, params) = (self.b, self.params);
        let mut record = empty_record("hookean-pcg", self.precond.to_string(), self.format);
        let n = b.len();
        let mut ws = CgWorkspace::new(n);
        let mut x = vec![0.0; n];
        let mut best_setup = f64::INFINITY;
        let mut best_solve = f64::INFINITY;
        let mut best_total = f64::INFINITY;
        // At most this many iterations are traced (pre-reserved: no
        // allocation while timing).
        let trace_len = if self.trace {
            params.max_iter.unwrap_or(2 * n).min(100_000) + 2
        } else {
            0
        };
        let mut trace = Vec::with_capacity(trace_len);
        for _ in 0..self.repeat {
            let heap = live_heap_bytes();
            let t0 = Instant::now();
            let new = AnyPreconditioner::from_options(self.precond);
            let setup = new.and_then(|mut p| p.setup(source).map(|()| p));
            let setup_s = t0.elapsed().as_secs_f64();
            let p = match setup {
                Ok(p) => p,
                Err(e) => {
                    record.error = Some(format!("preconditioner setup: {e}"));
                    return record;
                }
            };
            let grown = growth_since(heap);
            record.setup_bytes = record.setup_bytes.max(grown);
            trace.clear();
            let t1 = Instant::now();
            let mut timed_out = false;
            let result = if self.trace || self.time_limit.is_some() {
                if self.trace {
                    trace.push((setup_s, 1.0));
                }
                let limit = self.time_limit.unwrap_or(f64::INFINITY);
                let mut on_iteration = |p: &CgProgress<'_>| {
                    let t = setup_s + t1.elapsed().as_secs_f64();
                    if self.trace && trace.len() < trace_len {
                        trace.push((t, p.relative_residual));
                    }
                    if t > limit {
                        timed_out = true;
                        return ControlFlow::Break(());
                    }
                    ControlFlow::Continue(())
                };
                pcg(m, &p, b, &mut x, params, &mut ws, Some(&mut on_iteration))
            } else {
                pcg(m, &p, b, &mut x, params, &mut ws, None)
            };
            let solve_s = t1.elapsed().as_secs_f64();
            match result {
                Ok(info) => {
                    record.iterations = info.iterations;
                    record.recursive_rel_residual = Some(info.relative_residual);
                    record.converged = info.converged;
                    record.timed_out = timed_out && !info.converged;
                    if let Some(c) = info.condition {
                        record.lambda_min = Some(c.lambda_min);
                        record.lambda_max = Some(c.lambda_max);
                        record.condition = Some(c.condition);
                    }
                }
                Err(e) => {
                    record.error = Some(self.explain(&e));
                    return record;
                }
            }
            best_setup = best_setup.min(setup_s);
            best_solve = best_solve.min(solve_s);
            if setup_s + solve_s < best_total {
                best_total = setup_s + solve_s;
                record.trace.clone_from(&trace);
            }
            if let AnyPreconditioner::Amg(amg) = &p {
                record.amg = Some(amg.stats().into());
            }
        }
        record.setup_s = best_setup;
        record.solve_s = best_solve;
        record.rel_residual = relative_residual(self.original, &x, b);
        // PCG checked the true residual on the matrix it solved (the same
        // values, perhaps scaled by a power of two or in block storage): on
        // the matrix as read, it must meet the tolerance too.
        record.converged &= record.rel_residual <= params.rtol;
        record
    }
}

fn run_direct(
    a: &sprs::CsMat<f64>,
    b: &[f64],
    rtol: f64,
    repeat: usize,
    max_bytes: u64,
    trace: bool,
) -> SolveRecord {
    let mut record = empty_record("faer-cholesky", "direct".into(), "csc-lower");
    let mut x = vec![0.0; b.len()];
    let mut best_setup = f64::INFINITY;
    let mut best_solve = f64::INFINITY;
    for _ in 0..repeat {
        let mut d = DirectCholesky::with_max_bytes(max_bytes);
        let heap = live_heap_bytes();
        let t0 = Instant::now();
        if let Err(e) = d.factor_csr(a) {
            record.error = Some(e.to_string());
            return record;
        }
        best_setup = best_setup.min(t0.elapsed().as_secs_f64());
        record.setup_bytes = record.setup_bytes.max(growth_since(heap));
        let t0 = Instant::now();
        if let Err(e) = d.solve(b, &mut x) {
            record.error = Some(e.to_string());
            return record;
        }
        best_solve = best_solve.min(t0.elapsed().as_secs_f64());
    }
    record.setup_s = best_setup;
    record.solve_s = best_solve;
    record.rel_residual = relative_residual(a, &x, b);
    // Converged means what it means for PCG: the residual meets the tolerance.
    record.converged = record.rel_residual <= rtol;
    if trace {
        record.trace = vec![
            (best_setup, 1.0),
            (best_setup + best_solve, record.rel_residual),
        ];
    }
    record
}
