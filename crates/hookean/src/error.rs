//! The facade's error type: every crate's error, plus scenes and output.

use hookean_sparse::Short;
use thiserror::Error;

/// Everything that can go wrong in a simulation run.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum HookeanError {
    /// From the integrators.
    #[error(transparent)]
    Ode(#[from] hookean_ode::OdeError),
    /// From the model.
    #[error(transparent)]
    MassSpring(#[from] hookean_massspring::MassSpringError),
    /// From the velocity filter.
    #[error(transparent)]
    Filter(#[from] hookean_filter::FilterError),
    /// From the sparse linear algebra.
    #[error(transparent)]
    Sparse(#[from] hookean_sparse::SparseError),
    /// A scene file is malformed: where and why.
    #[error("{file}:{line}:{column}: {message}")]
    Scene {
        /// The scene file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A `key=value` override of a scene ([`Scene::with_overrides`](crate::scene::Scene::with_overrides))
    /// that is malformed or makes the scene invalid.
    #[error("{file}: override {arg}: {message}")]
    Override {
        /// The scene file.
        file: String,
        /// The override as given.
        arg: String,
        /// What is wrong.
        message: String,
    },
    /// A scene table whose values each parse but do not make a model (a
    /// jelly of 0 particles, a cloth so large its springs have infinite
    /// length, a filter on an implicit method): the table and the reason.
    #[error("[{table}]: {message}")]
    Build {
        /// The table (`cloth`, `jelly`, `filter`, `collider 2`, ...).
        table: String,
        /// The builder's reason.
        message: String,
    },
    /// An option combination that cannot work.
    #[error("invalid option {name}: {message}")]
    InvalidOption {
        /// The option.
        name: String,
        /// Why.
        message: String,
    },
    /// A scene whose model would need more memory than allowed (see
    /// `Scene::build_within`); `bytes` is `None` when its size overflows
    /// 64-bit arithmetic.
    #[error(
        "{key}: the model would need {}, more than the {:.1} GiB allowed",
        bytes.map_or("more than 2^64 bytes".to_string(), |b| format!("about {:.1} GiB", b as f64 / (1u64 << 30) as f64)),
        *max_bytes as f64 / (1u64 << 30) as f64
    )]
    TooLarge {
        /// The scene key that sets the size (`cloth.n`, `jelly.n`, ...).
        key: &'static str,
        /// The estimate.
        bytes: Option<u64>,
        /// The cap.
        max_bytes: u64,
    },
    /// The run blew up: its total energy grew past what the scene started
    /// with (and its moving colliders can give) by far more than any valid
    /// motion can (see [`Simulation`](crate::Simulation)'s energy check).
    #[error(
        "the run blew up at t = {} s (step {step}): the {term} energy grew from {term_start:.4e} J to {term_now:.4e} J; the total energy {energy:.4e} J exceeds {bound:.4e} J, the start plus {factor:e} times the scene's energy scale{}",
        short_time(*t),
        blow_up_hint(*h, *dt_max)
    )]
    BlowUp {
        /// Simulated time of the first state past the bound.
        t: f64,
        /// Accepted steps so far.
        step: usize,
        /// Total energy of that state (J; NaN for a state that is not finite).
        energy: f64,
        /// The bound (J).
        bound: f64,
        /// The growth factor of the bound (`SimulationOptions::blow_up_factor`).
        factor: f64,
        /// The term that grew the most (`"kinetic"`, `"gravitational"`,
        /// `"spring"`, `"external-force"`; a term that is not finite first).
        term: &'static str,
        /// That term at the start (J).
        term_start: f64,
        /// That term now (J).
        term_now: f64,
        /// The step size of the last step.
        h: f64,
        /// The explicit stability limit `2 / sqrt(k0)` at the starting
        /// positions (the filtering paper's eq. 11) for explicit methods.
        dt_max: Option<f64>,
    },
    /// A step gained energy that nothing in the scene can give, and gained
    /// it again when redone in substeps: its total energy (counted after
    /// the put-back of the particles it left inside a collider) exceeds
    /// the start plus what moving colliders and driven pins can give plus
    /// [`SimulationOptions::energy_budget`](crate::SimulationOptions::energy_budget)
    /// times the scene's energy scale (docs/CONTACT.md, "Energy").
    #[error(
        "the run gained energy at t = {} s (step {step}): the {term} energy went from {} J at the start to {} J; the total energy {} J exceeds {} J, the start plus what moving colliders and driven pins can give plus integrator.energy_budget = {} times the scene's energy scale, even with the step split into {substeps} substeps; lower integrator.h (or integrator.h_max), tighten solver.newton_rtol, or allow the integrator's own error with a larger integrator.energy_budget",
        short_time(*t),
        Short(*term_start),
        Short(*term_now),
        Short(*energy),
        Short(*budget),
        Short(*fraction)
    )]
    EnergyGain {
        /// Simulated time of the first state past the budget.
        t: f64,
        /// Accepted steps so far.
        step: usize,
        /// Total energy of that state after the contact put-back (J).
        energy: f64,
        /// The budget (J).
        budget: f64,
        /// The budget's fraction of the energy scale
        /// (`SimulationOptions::energy_budget`).
        fraction: f64,
        /// The term that grew the most (as [`HookeanError::BlowUp`]'s).
        term: &'static str,
        /// That term at the start (J).
        term_start: f64,
        /// That term now (J).
        term_now: f64,
        /// The substeps of the last attempt.
        substeps: usize,
    },
    /// Reading or writing a file failed. `From<std::io::Error>` makes one
    /// without a path; [`Error::source`](std::error::Error::source) gives
    /// the operating system's error.
    #[error("{}{source}", path_prefix(.path.as_deref()))]
    Io {
        /// The file, when known.
        path: Option<std::path::PathBuf>,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
}

/// A time in seconds with about 6 significant digits.
fn short_time(t: f64) -> String {
    let s = format!("{t:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if t != 0.0 && t.abs() < 1e-3 {
        format!("{t:.5e}")
    } else {
        s.to_string()
    }
}

/// The advice of [`HookeanError::BlowUp`]: the stable step, where known.
fn blow_up_hint(h: f64, dt_max: Option<f64>) -> String {
    match dt_max {
        Some(d) if h > d => format!(
            "; the step h = {h:.3e} s is above the stable step dt_max = {d:.3e} s \
             (eq. 11 of the filtering paper): lower integrator.h, add a filter or use an implicit method"
        ),
        Some(d) => format!(
            "; the step h = {h:.3e} s is below dt_max = {d:.3e} s at the start, \
             the model may have stiffened as it moved: lower integrator.h or use an implicit method"
        ),
        None => String::new(),
    }
}

/// `"path: "` before an I/O error's message, when the path is known.
fn path_prefix(path: Option<&std::path::Path>) -> String {
    path.map_or_else(String::new, |p| format!("{}: ", p.display()))
}

impl HookeanError {
    /// An I/O error on the file `path`.
    pub fn io(path: impl AsRef<std::path::Path>, source: std::io::Error) -> Self {
        HookeanError::Io {
            path: Some(path.as_ref().to_path_buf()),
            source,
        }
    }
}

impl HookeanError {
    /// `self` with `path` named, if it is an I/O error (its own or the
    /// model's writer's) without one.
    pub(crate) fn at_path(self, path: &std::path::Path) -> Self {
        match self {
            HookeanError::Io { path: None, source } => HookeanError::io(path, source),
            HookeanError::MassSpring(hookean_massspring::MassSpringError::Io {
                message, ..
            }) => HookeanError::io(path, std::io::Error::other(message)),
            e => e,
        }
    }
}

impl From<std::io::Error> for HookeanError {
    fn from(source: std::io::Error) -> Self {
        HookeanError::Io { path: None, source }
    }
}
