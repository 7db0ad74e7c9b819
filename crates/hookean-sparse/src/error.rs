//! The one error type of `hookean-sparse`.

use thiserror::Error;

/// Everything that can go wrong in `hookean-sparse`.
///
/// Variants are structured so that a caller can react (retry with a smaller
/// step, choose another preconditioner) without parsing messages.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SparseError {
    /// A vector or matrix has the wrong size.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was being checked (`"right-hand side"`, `"x"`, ...).
        what: &'static str,
        /// The size that was required.
        expected: usize,
        /// The size that was given.
        found: usize,
    },
    /// A matrix that must be square is not.
    #[error("matrix is not square: {rows} x {cols}")]
    NotSquare {
        /// Number of rows.
        rows: usize,
        /// Number of columns.
        cols: usize,
    },
    /// A scalar dimension is not a multiple of 3 where 3x3 blocks are needed.
    #[error("dimension {dim} is not a multiple of 3: cannot form 3x3 blocks")]
    NotBlockAligned {
        /// The offending dimension.
        dim: usize,
    },
    /// A block index lies outside the matrix.
    #[error("block index ({row}, {col}) is outside a matrix of {n} block rows")]
    BlockIndexOutOfRange {
        /// Block row.
        row: usize,
        /// Block column.
        col: usize,
        /// Number of block rows.
        n: usize,
    },
    /// A block was written that is not in the sparsity pattern built at construction.
    #[error("block ({row}, {col}) is not in the sparsity pattern")]
    NotInPattern {
        /// Block row.
        row: usize,
        /// Block column.
        col: usize,
    },
    /// A matrix that must be symmetric is not.
    #[error("matrix is not symmetric: entry ({row}, {col}) differs from its transpose")]
    NotSymmetric {
        /// Row of the first asymmetric entry found.
        row: usize,
        /// Column of the first asymmetric entry found.
        col: usize,
    },
    /// CG met a direction of non-positive curvature: the matrix is not
    /// symmetric positive definite.
    #[error(
        "matrix is not positive definite: p^T A p = {curvature:.5e} at CG iteration {iteration}"
    )]
    NotPositiveDefinite {
        /// Iteration (0-based) at which the curvature was found.
        iteration: usize,
        /// The value of p^T A p.
        curvature: f64,
    },
    /// CG met a residual with `r . M^-1 r <= 0`: the preconditioner `M^-1`
    /// is not positive definite (a multigrid whose smoother diverges, an
    /// incomplete factorisation or block Jacobi of an indefinite matrix),
    /// whatever the matrix is.
    #[error(
        "the preconditioner is not positive definite: r^T M^-1 r = {value:.5e} at CG iteration {iteration}"
    )]
    PreconditionerNotPositiveDefinite {
        /// Iteration (0-based) at which it was found.
        iteration: usize,
        /// The value of r^T M^-1 r.
        value: f64,
    },
    /// A NaN or an infinity was found.
    #[error("non-finite value (NaN or infinity) in {what}{}", index.map(|i| format!(" at index {i}")).unwrap_or_default())]
    NonFinite {
        /// Where it was found.
        what: &'static str,
        /// The first offending index, when known.
        index: Option<usize>,
    },
    /// An iterative method stopped at its iteration limit.
    #[error(
        "{method} did not converge in {iterations} iterations: relative residual {relative_residual:e}"
    )]
    NotConverged {
        /// The method (`"PCG"`, `"power method"`).
        method: &'static str,
        /// Iterations performed.
        iterations: usize,
        /// Relative residual (or relative change) reached.
        relative_residual: f64,
    },
    /// The right-hand side is so small or so large that the squares of the
    /// solver's inner products would underflow or overflow (its largest
    /// entry outside `[1e-150, 1e150]`): a norm of zero would report
    /// convergence at `x = 0`. Scale the system (by a power of two, which
    /// is exact).
    #[error(
        "the system is badly scaled: the largest entry of {what} is {largest:e}, outside [1e-150, 1e150]; scale it (by a power of two, exactly)"
    )]
    BadlyScaled {
        /// Which vector (`"right-hand side b"`).
        what: &'static str,
        /// Its largest absolute entry.
        largest: f64,
    },
    /// A solver or preconditioner was given a system of no unknowns.
    #[error("{what} is empty (0 x 0): there is nothing to solve")]
    Empty {
        /// What was empty (`"matrix"`).
        what: &'static str,
    },
    /// A preconditioner for symmetric matrices was given a scalar CSR matrix
    /// that stores only one triangle. `sprs::CsMat` holds exactly what it is
    /// given, and the scalar-CSR paths read both triangles: half of a
    /// symmetric matrix would be factored (IC(0)) or smoothed (SSOR,
    /// multigrid) as a different, triangular matrix.
    #[error(
        "{preconditioner} needs both triangles of a symmetric matrix, but only the {stored} \
         triangle is stored: add the transpose of its off-diagonal part (a + a^T - diag(a)), \
         or use Jacobi or a direct solver for a triangular system"
    )]
    OneTriangle {
        /// The preconditioner that refused the matrix.
        preconditioner: &'static str,
        /// `"upper"` or `"lower"`: the triangle that holds every off-diagonal entry.
        stored: &'static str,
    },
    /// A preconditioner needs a positive diagonal and found otherwise.
    #[error("{preconditioner} needs a positive diagonal, but entry {row} is {value:?}")]
    NonPositiveDiagonal {
        /// The preconditioner that failed.
        preconditioner: &'static str,
        /// Scalar row of the offending diagonal entry.
        row: usize,
        /// Its value.
        value: f64,
    },
    /// A 3x3 diagonal block could not be inverted.
    #[error("3x3 diagonal block {block} is singular (determinant {determinant:e})")]
    SingularBlock {
        /// Block row.
        block: usize,
        /// Its determinant.
        determinant: f64,
    },
    /// Multigrid met an operator that is not positive definite on some level
    /// (a diagonal block of a coarse operator, or the coarsest operator's
    /// factorisation).
    #[error("AMG level {level}: {what} is not positive definite (scalar row {row})")]
    AmgNotPositiveDefinite {
        /// Level (0 is the finest).
        level: usize,
        /// Scalar row of that level where it was found.
        row: usize,
        /// Which operator: `"diagonal block"` or `"coarsest operator"`.
        what: &'static str,
    },
    /// A near-nullspace vector does not have the matrix's dimension.
    #[error("near-nullspace vector {vector} has {found} entries, the matrix has {expected} rows")]
    NullspaceLength {
        /// Which vector (0-based).
        vector: usize,
        /// The matrix dimension.
        expected: usize,
        /// The vector's length.
        found: usize,
    },
    /// Incomplete Cholesky found no positive pivots even with a large diagonal shift.
    #[error(
        "incomplete Cholesky failed: pivot {row} not positive even with diagonal shift {shift:e}"
    )]
    IncompleteCholeskyFailed {
        /// Scalar row of the last failing pivot.
        row: usize,
        /// The largest shift tried (relative to the unit-diagonal scaled matrix).
        shift: f64,
    },
    /// An argument is out of its admissible range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// A constraint direction is zero or lies in the span of the particle's other constraints.
    #[error("constraint direction for particle {particle} is degenerate (zero or dependent)")]
    DegenerateConstraint {
        /// The particle.
        particle: usize,
    },
    /// A Matrix Market file is malformed (`file:line: message`, as compilers
    /// write it; the file is `<input>` when reading from a reader).
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong there.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The direct (sparse Cholesky) baseline failed.
    #[error("sparse Cholesky failed: {message}")]
    Direct {
        /// faer's message.
        message: String,
    },
    /// A constructor was asked for more memory than can be allocated (the
    /// size overflows, or the allocator refused it); nothing was allocated.
    #[error("{what} of {entries} entries cannot be allocated ({})", bytes_text(*.bytes))]
    TooLarge {
        /// What was to be allocated (`"CG workspace"`).
        what: &'static str,
        /// The entries asked for.
        entries: usize,
        /// Their size in bytes, `None` when it overflows.
        bytes: Option<usize>,
    },
}

/// `about 3.4e10 bytes` or `more than 2^64 bytes`, for [`SparseError::TooLarge`].
fn bytes_text(bytes: Option<usize>) -> String {
    match bytes {
        Some(b) => format!("{:.3e} bytes", b as f64),
        None => "more bytes than the address space holds".into(),
    }
}

/// A vector of `n` copies of `value`, or [`SparseError::TooLarge`] when the
/// allocator cannot give it (instead of an abort or a capacity-overflow panic).
pub(crate) fn try_filled<T: Clone>(
    what: &'static str,
    n: usize,
    value: T,
) -> Result<Vec<T>, SparseError> {
    let mut v = Vec::new();
    try_grow(what, &mut v, n)?;
    v.resize(n, value);
    Ok(v)
}

/// Reserves room for `additional` more entries in `v`, or
/// [`SparseError::TooLarge`].
pub(crate) fn try_grow<T>(
    what: &'static str,
    v: &mut Vec<T>,
    additional: usize,
) -> Result<(), SparseError> {
    v.try_reserve_exact(additional)
        .map_err(|_| SparseError::TooLarge {
            what,
            entries: additional,
            bytes: additional.checked_mul(std::mem::size_of::<T>()),
        })
}

/// Checks that `v` has length `expected`.
pub(crate) fn check_len(what: &'static str, v: &[f64], expected: usize) -> Result<(), SparseError> {
    if v.len() == expected {
        Ok(())
    } else {
        Err(SparseError::DimensionMismatch {
            what,
            expected,
            found: v.len(),
        })
    }
}

/// Checks that every entry of `v` is finite.
pub(crate) fn check_finite(what: &'static str, v: &[f64]) -> Result<(), SparseError> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(SparseError::NonFinite {
            what,
            index: Some(i),
        }),
    }
}

/// Refuses a system of no unknowns ([`SparseError::Empty`]): every solver
/// and preconditioner set-up calls this first.
pub(crate) fn non_empty(what: &'static str, n: usize) -> Result<usize, SparseError> {
    if n == 0 {
        Err(SparseError::Empty { what })
    } else {
        Ok(n)
    }
}
