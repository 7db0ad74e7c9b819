//! The one error type of `hookean-massspring`.

use hookean_sparse::SparseError;
use thiserror::Error;

/// Everything that can go wrong while building or evaluating a mass-spring model.
///
/// Structured variants, so that callers can react without parsing messages;
/// errors of `hookean-sparse` are wrapped with `#[from]`.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MassSpringError {
    /// A spring names a particle that does not exist.
    #[error("spring {spring} names particle {particle}, but the model has {n_particles} particles")]
    ParticleOutOfRange {
        /// Index of the spring.
        spring: usize,
        /// The offending particle index.
        particle: usize,
        /// Number of particles.
        n_particles: usize,
    },
    /// A particle index given to a model method is out of range.
    #[error("particle {particle} is out of range (the model has {n_particles} particles)")]
    NoSuchParticle {
        /// The offending particle index.
        particle: usize,
        /// Number of particles.
        n_particles: usize,
    },
    /// A spring joins a particle to itself.
    #[error("spring {spring} joins particle {particle} to itself")]
    SelfSpring {
        /// Index of the spring.
        spring: usize,
        /// The particle.
        particle: usize,
    },
    /// A spring's endpoints coincide (its direction is undefined), or its rest length is zero.
    #[error("spring {spring} between particles {i} and {j} has zero length")]
    ZeroLengthSpring {
        /// Index of the spring.
        spring: usize,
        /// First particle.
        i: usize,
        /// Second particle.
        j: usize,
    },
    /// A spring parameter (rest length, stiffness, damping) is negative or not finite.
    #[error("spring {spring}: invalid {parameter} {value:?}")]
    InvalidSpring {
        /// Index of the spring.
        spring: usize,
        /// `"rest length"`, `"stiffness"` or `"damping"`.
        parameter: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A particle mass is zero, negative or not finite.
    #[error("particle {particle} has invalid mass {mass:?} (must be positive and finite)")]
    InvalidMass {
        /// The particle.
        particle: usize,
        /// The offending mass.
        mass: f64,
    },
    /// A vector has the wrong length.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was checked (`"x"`, `"v"`, ...).
        what: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        found: usize,
    },
    /// A NaN or infinity in a state or parameter.
    #[error("non-finite value in {what} at index {index}")]
    NonFinite {
        /// Where (`"x"`, `"v"`, `"gravity"`, ...).
        what: &'static str,
        /// The first offending index.
        index: usize,
    },
    /// A scalar parameter is out of its admissible range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// A malformed OBJ file.
    #[error("OBJ line {line}: {message}")]
    ObjParse {
        /// 1-based line number.
        line: usize,
        /// What is wrong there.
        message: String,
    },
    /// A mesh file that cannot serve as a model or a contact surface.
    #[error("{path}{}: {message}", line.map_or(String::new(), |l| format!(":{l}")))]
    MeshFile {
        /// The file.
        path: String,
        /// The 1-based line to blame, if one is.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file (or `"<writer>"`).
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The power method for the largest eigenvalue did not settle.
    #[error("power method did not converge in {iterations} iterations (estimate {estimate:e})")]
    PowerMethodNotConverged {
        /// Iterations performed.
        iterations: usize,
        /// Last estimate.
        estimate: f64,
    },
    /// An error of the sparse linear algebra layer.
    #[error(transparent)]
    Sparse(#[from] SparseError),
}

/// Checks that `v` has length `expected` and only finite entries.
pub(crate) fn check_vec(
    what: &'static str,
    v: &[f64],
    expected: usize,
) -> Result<(), MassSpringError> {
    if v.len() != expected {
        return Err(MassSpringError::DimensionMismatch {
            what,
            expected,
            found: v.len(),
        });
    }
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(index) => Err(MassSpringError::NonFinite { what, index }),
    }
}

pub(crate) fn io_err(path: &str, e: std::io::Error) -> MassSpringError {
    MassSpringError::Io {
        path: path.to_string(),
        message: e.to_string(),
    }
}
