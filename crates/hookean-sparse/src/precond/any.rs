//! Choosing a preconditioner by name (scene files, the command line).

use crate::NonExhaustive;
use std::fmt;
use std::str::FromStr;

use super::{
    Amg, AmgOptions, BlockJacobi, Identity, IncompleteCholesky, Jacobi, Preconditioner,
    PreconditionerSetup, Ssor,
};
use crate::error::SparseError;

/// The preconditioners of this crate, by name.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PrecondKind {
    /// [`Identity`]: `none`.
    None,
    /// [`Jacobi`]: `jacobi`.
    Jacobi,
    /// [`BlockJacobi`]: `block-jacobi`, with nodes of
    /// [`AmgOptions::block_size`] unknowns on CSR (3 on block storage).
    BlockJacobi,
    /// [`Ssor`] with its relaxation: `ssor`.
    Ssor {
        /// Relaxation in (0, 2).
        omega: f64,
    },
    /// [`IncompleteCholesky`]: `ic0`.
    Ic0,
    /// [`IncompleteCholesky::modified`] (block matrices only): `mic0`.
    Mic0 {
        /// Relaxation in [0, 1].
        omega: f64,
    },
    /// [`Amg`]: `amg`, with the options of
    /// [`PreconditionerOptions::amg`].
    Amg,
}

impl PrecondKind {
    /// The default MIC(0) relaxation, chosen on the drape's systems
    /// (docs/PERFORMANCE.md): 0.99.
    pub const MIC_OMEGA: f64 = 0.99;

    /// From this many 3x3 block rows (particles of a cloth) on,
    /// [`auto_for_blocks`](Self::auto_for_blocks) picks the multigrid.
    pub const AUTO_AMG_BLOCKS: usize = 10_000;

    /// The preconditioner measured fastest for the implicit cloth step of
    /// `n_blocks` block rows (docs/PERFORMANCE.md, issues 16 and 25): MIC(0)
    /// (relaxation [`MIC_OMEGA`](Self::MIC_OMEGA)) below
    /// [`AUTO_AMG_BLOCKS`](Self::AUTO_AMG_BLOCKS), smoothed-aggregation
    /// multigrid from there on. The rule `preconditioner = "auto"` of scene
    /// files applies.
    ///
    /// ```
    /// use hookean_sparse::PrecondKind;
    /// assert_eq!(PrecondKind::auto_for_blocks(64 * 64), PrecondKind::Mic0 { omega: 0.99 });
    /// assert_eq!(PrecondKind::auto_for_blocks(128 * 128), PrecondKind::Amg);
    /// ```
    pub fn auto_for_blocks(n_blocks: usize) -> Self {
        if n_blocks >= Self::AUTO_AMG_BLOCKS {
            PrecondKind::Amg
        } else {
            PrecondKind::Mic0 {
                omega: Self::MIC_OMEGA,
            }
        }
    }

    /// Every kind that works on both matrix types (all but MIC(0)), with
    /// SSOR at `omega`.
    pub fn all(omega: f64) -> [PrecondKind; 6] {
        [
            PrecondKind::None,
            PrecondKind::Jacobi,
            PrecondKind::BlockJacobi,
            PrecondKind::Ssor { omega },
            PrecondKind::Ic0,
            PrecondKind::Amg,
        ]
    }

    /// The name used on the command line and in scene files.
    pub fn name(&self) -> &'static str {
        match self {
            PrecondKind::None => "none",
            PrecondKind::Jacobi => "jacobi",
            PrecondKind::BlockJacobi => "block-jacobi",
            PrecondKind::Ssor { .. } => "ssor",
            PrecondKind::Ic0 => "ic0",
            PrecondKind::Mic0 { .. } => "mic0",
            PrecondKind::Amg => "amg",
        }
    }
}

impl fmt::Display for PrecondKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for PrecondKind {
    type Err = SparseError;

    /// Parses `none`, `jacobi`, `block-jacobi`, `ssor` (omega 1), `ic0`,
    /// `mic0` (omega [`MIC_OMEGA`](Self::MIC_OMEGA)) or `amg`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "none" => PrecondKind::None,
            "jacobi" => PrecondKind::Jacobi,
            "block-jacobi" => PrecondKind::BlockJacobi,
            "ssor" => PrecondKind::Ssor { omega: 1.0 },
            "ic0" => PrecondKind::Ic0,
            "mic0" => PrecondKind::Mic0 {
                omega: PrecondKind::MIC_OMEGA,
            },
            "amg" => PrecondKind::Amg,
            other => {
                return Err(SparseError::InvalidParameter {
                    name: "preconditioner",
                    message: format!(
                        "unknown preconditioner '{other}' (expected none, jacobi, block-jacobi, ssor, ic0, mic0 or amg)"
                    ),
                });
            }
        })
    }
}

/// Which preconditioner, with its settings: the one value by which PCG,
/// GMRES, a scene's `[solver]` table and the command line choose a
/// preconditioner ([`AnyPreconditioner::from_options`]).
///
/// ```
/// use hookean_sparse::{AmgOptions, AmgSmoother, PrecondKind, PreconditionerOptions};
/// // A kind without multigrid settings:
/// let ic0 = PreconditionerOptions::from(PrecondKind::Ic0);
/// assert_eq!(ic0.amg, AmgOptions::default());
/// // The multigrid with two block-IC(0) sweeps:
/// let amg = PreconditionerOptions {
///     kind: PrecondKind::Amg,
///     amg: AmgOptions { smoother: AmgSmoother::BlockIc0, sweeps: 2, ..Default::default() },
///     ..Default::default()
/// };
/// assert_eq!(amg.kind.name(), "amg");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PreconditionerOptions {
    /// Which preconditioner (with SSOR's and MIC(0)'s relaxation). Default
    /// block-Jacobi.
    pub kind: PrecondKind,
    /// The multigrid's options, used when `kind` is [`PrecondKind::Amg`]
    /// (including what each `setup` on new values does: refill, keep,
    /// rebuild). Default [`AmgOptions::default`]. Its
    /// [`block_size`](AmgOptions::block_size), the system's unknowns per
    /// node on CSR storage, is block Jacobi's node size too.
    pub amg: AmgOptions,
    /// Build with `..Default::default()` or `From<PrecondKind>` (see
    /// [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for PreconditionerOptions {
    fn default() -> Self {
        PrecondKind::BlockJacobi.into()
    }
}

impl From<PrecondKind> for PreconditionerOptions {
    /// `kind` with the default multigrid options.
    fn from(kind: PrecondKind) -> Self {
        Self {
            kind,
            amg: AmgOptions::default(),
            non_exhaustive: NonExhaustive(()),
        }
    }
}

impl fmt::Display for PreconditionerOptions {
    /// The kind's name (`amg`, `mic0`, ...).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.kind.fmt(f)
    }
}

/// Any preconditioner of this crate, chosen at run time.
///
/// Dispatch is one `match` per application, outside the inner loops.
#[derive(Debug, Clone)]
pub enum AnyPreconditioner {
    /// No preconditioning.
    None(Identity),
    /// Diagonal.
    Jacobi(Jacobi),
    /// Block diagonal, one block per node.
    BlockJacobi(BlockJacobi),
    /// SSOR.
    Ssor(Ssor),
    /// IC(0) or MIC(0).
    Ic0(IncompleteCholesky),
    /// Smoothed-aggregation multigrid.
    Amg(Amg),
}

impl AnyPreconditioner {
    /// An empty preconditioner as `options` name it (set it up with
    /// [`PreconditionerSetup::setup`]).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] for an SSOR `omega` outside (0, 2),
    /// a MIC(0) `omega` outside [0, 1], and as [`Amg::with_options`].
    pub fn from_options(options: &PreconditionerOptions) -> Result<Self, SparseError> {
        Ok(match options.kind {
            PrecondKind::None => AnyPreconditioner::None(Identity),
            PrecondKind::Jacobi => AnyPreconditioner::Jacobi(Jacobi::new()),
            PrecondKind::BlockJacobi => AnyPreconditioner::BlockJacobi(
                BlockJacobi::with_block_size(options.amg.block_size)?,
            ),
            PrecondKind::Ssor { omega } => AnyPreconditioner::Ssor(Ssor::new(omega)?),
            PrecondKind::Ic0 => AnyPreconditioner::Ic0(IncompleteCholesky::new()),
            PrecondKind::Mic0 { omega } => {
                AnyPreconditioner::Ic0(IncompleteCholesky::modified(omega)?)
            }
            PrecondKind::Amg => AnyPreconditioner::Amg(Amg::with_options(options.amg.clone())?),
        })
    }

    /// [`from_options`](Self::from_options) of `kind` with the default
    /// multigrid options.
    ///
    /// # Errors
    /// As [`from_options`](Self::from_options).
    pub fn new(kind: PrecondKind) -> Result<Self, SparseError> {
        Self::from_options(&kind.into())
    }

    /// Its kind.
    pub fn kind(&self) -> PrecondKind {
        match self {
            AnyPreconditioner::None(_) => PrecondKind::None,
            AnyPreconditioner::Jacobi(_) => PrecondKind::Jacobi,
            AnyPreconditioner::BlockJacobi(_) => PrecondKind::BlockJacobi,
            AnyPreconditioner::Ssor(p) => PrecondKind::Ssor { omega: p.omega() },
            AnyPreconditioner::Ic0(p) if p.relaxation() != 0.0 => PrecondKind::Mic0 {
                omega: p.relaxation(),
            },
            AnyPreconditioner::Ic0(_) => PrecondKind::Ic0,
            AnyPreconditioner::Amg(_) => PrecondKind::Amg,
        }
    }
}

macro_rules! dispatch {
    ($self:expr, $p:ident => $e:expr) => {
        match $self {
            AnyPreconditioner::None($p) => $e,
            AnyPreconditioner::Jacobi($p) => $e,
            AnyPreconditioner::BlockJacobi($p) => $e,
            AnyPreconditioner::Ssor($p) => $e,
            AnyPreconditioner::Ic0($p) => $e,
            AnyPreconditioner::Amg($p) => $e,
        }
    };
}

impl Preconditioner for AnyPreconditioner {
    fn dim(&self) -> Option<usize> {
        dispatch!(self, p => p.dim())
    }
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        dispatch!(self, p => p.apply(r, z))
    }
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        dispatch!(self, p => p.apply_dot(r, z))
    }
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        dispatch!(self, pc => pc.update_and_apply(alpha, q, r, z))
    }
    fn costly(&self) -> bool {
        dispatch!(self, pc => pc.costly())
    }
}

impl<A: ?Sized> PreconditionerSetup<A> for AnyPreconditioner
where
    Identity: PreconditionerSetup<A>,
    Jacobi: PreconditionerSetup<A>,
    BlockJacobi: PreconditionerSetup<A>,
    Ssor: PreconditionerSetup<A>,
    IncompleteCholesky: PreconditionerSetup<A>,
    Amg: PreconditionerSetup<A>,
{
    fn setup(&mut self, a: &A) -> Result<(), SparseError> {
        dispatch!(self, p => p.setup(a))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for kind in PrecondKind::all(1.0) {
            assert_eq!(kind.name().parse::<PrecondKind>().unwrap(), kind);
            assert_eq!(AnyPreconditioner::new(kind).unwrap().kind(), kind);
        }
        assert!("ilu".parse::<PrecondKind>().is_err());
        let mic = PrecondKind::Mic0 {
            omega: PrecondKind::MIC_OMEGA,
        };
        assert_eq!("mic0".parse::<PrecondKind>().unwrap(), mic);
        assert_eq!(AnyPreconditioner::new(mic).unwrap().kind(), mic);
        assert!(AnyPreconditioner::new(PrecondKind::Mic0 { omega: 2.0 }).is_err());
    }
}
