#![doc = include_str!("../README.md")]
//!
//! # The crate's map
//!
//! - [`SymBlockMatrix`]: symmetric block CSR (diagonal + upper 3x3 blocks).
//!   The pattern ([`BlockPattern`]) is built once per topology; values are
//!   refilled in place every step ([`SymBlockMatrix::add_to_block`],
//!   or [`SymBlockMatrix::add_to_slot`] with cached slots).
//! - [`LinearOperator`]: `y = A x`, for the block matrix, `sprs::CsMat<f64>`,
//!   the scalar symmetric [`SymCsrMatrix`] (upper triangle, half the bytes
//!   per product) and closures ([`MatrixFree`]).
//! - [`Preconditioner`] / [`PreconditionerSetup`]: [`Identity`], [`Jacobi`],
//!   [`BlockJacobi`], [`Ssor`], [`IncompleteCholesky`] (IC(0), and MIC(0)
//!   with [`IncompleteCholesky::modified`]) and smoothed-aggregation
//!   multigrid [`Amg`]; [`AnyPreconditioner`] picks one by name, or from a
//!   [`PreconditionerOptions`] (the kind with its settings) through
//!   [`AnyPreconditioner::from_options`].
//! - [`Pcg`], a solver value holding its parameters and workspace
//!   (`Pcg::new(params).solve(&a, &precond, &b, &mut x)`), and the free
//!   functions [`pcg`] and [`filtered_pcg`] (Baraff-Witkin's filtered CG, the
//!   tutorial's Algorithm 4) with [`CgParams`], a reusable [`CgWorkspace`]
//!   and an optional per-iteration callback; they return [`CgInfo`].
//! - [`gmres`]: restarted, right-preconditioned GMRES for nonsymmetric
//!   systems, with [`GmresParams`] and a reusable [`GmresWorkspace`]; it
//!   returns [`GmresInfo`].
//! - [`SymBlockMatrix::from_blocks`] builds a matrix from block triplets
//!   (duplicates summed); the scalar-CSR path speaks `sprs`, re-exported as
//!   [`sprs`], and its symmetric preconditioners need both triangles stored.
//!   [`CscCopy`] keeps a general `sprs` matrix's column-major copy (the
//!   layout faer's sparse factorisations read) across refills.
//! - [`power_method`] with a hook between iterations (the filtering paper's
//!   modified power method).
//! - [`read_matrix_market`] / [`write_matrix_market`], and `DirectCholesky`
//!   (faer's sparse Cholesky, behind the default feature `faer`) as the
//!   exact baseline. Without that feature the crate does not depend on faer.
//!
//! # Example: one implicit step of a tiny spring chain
//!
//! ```
//! use std::sync::Arc;
//! use hookean_sparse::*;
//!
//! // Three particles in a chain: blocks (0,1) and (1,2).
//! let pattern = Arc::new(BlockPattern::new(3, [(0, 1), (1, 2)])?);
//! let mut a = SymBlockMatrix::new(pattern);
//! let (m, h, k) = (0.1, 0.01, 1e4);
//! let spring = block::scale(&block::IDENTITY, h * h * k);
//! for (i, j) in [(0, 1), (1, 2)] {
//!     a.add_to_block(i, i, &spring)?;
//!     a.add_to_block(j, j, &spring)?;
//!     a.add_to_block(i, j, &block::scale(&spring, -1.0))?;
//! }
//! a.add_to_diagonal(&[m; 9])?; // A = M + h^2 K
//!
//! let mut precond = IncompleteCholesky::new();
//! precond.setup(&a)?;
//! let b = [0.0, 0.0, -9.81 * m * h, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
//! let mut dv = [0.0; 9];
//! let mut pinned = Constraints::new(3);
//! pinned.pin(2, [0.0; 3])?; // the last particle is nailed down
//! let info = Pcg::new(CgParams::default()).solve_filtered(&a, &precond, &b, &mut dv, &pinned)?;
//! assert!(info.converged);
//! assert_eq!(&dv[6..], &[0.0, 0.0, 0.0]);
//! # Ok::<(), SparseError>(())
//! ```
//!
//! # Options structs
//!
//! [`CgParams`], [`GmresParams`], [`PowerParams`], [`AmgOptions`],
//! and [`ReadOptions`] have a `Default`:
//! construct them with `..Default::default()`. Each has a hidden field, so
//! that a later version may add an option without breaking your code; a
//! literal naming every field does not compile outside this crate.
//!
//! ```
//! use hookean_sparse::{CgParams, InitialGuess};
//! let params = CgParams { rtol: 1e-10, max_iter: Some(500), ..Default::default() };
//! assert_eq!((params.rtol, params.max_iter), (1e-10, Some(500)));
//! assert_eq!(params.initial_guess, InitialGuess::Zero); // the default
//! ```
//!
//! ```compile_fail
//! // Every field named, none left to the default: refused outside the crate.
//! let params = hookean_sparse::PowerParams { max_iter: 100, rtol: 1e-6, seed: 1 };
//! ```

crate::non_exhaustive_seal!();

pub mod block;
mod cg;
mod constraints;
mod csc;
#[cfg(feature = "faer")]
mod direct;
mod error;
mod gmres;
mod iso;
mod lanczos;
mod matrix;
mod mtx;
mod operator;
pub mod par;
mod pcg_matrix;
mod power;
mod precond;
pub mod seal;
pub mod short;
mod symcsr;
mod transpose;
pub mod vecops;

/// `sprs`, which the scalar-CSR part of this API speaks (`sprs::CsMat<f64>`
/// as a [`LinearOperator`], [`SymBlockMatrix::from_csr`],
/// [`MatrixMarket::into_csr`]): use this re-export to get the same version.
pub use sprs;

pub use block::Block3;
pub use cg::{
    CgCallback, CgInfo, CgParams, CgProgress, CgWorkspace, InitialGuess, NegativeCurvature, Pcg,
    filtered_pcg, pcg,
};
pub use constraints::Constraints;
pub use csc::CscCopy;
#[cfg(feature = "faer")]
pub use direct::DirectCholesky;
pub use error::SparseError;
pub use gmres::{GmresInfo, GmresParams, GmresWorkspace, gmres};
pub use iso::{IsoBlockMatrix, IsoSlot};
pub use lanczos::{ConditionEstimate, LANCZOS_CAPACITY};
pub use matrix::{
    BlockPattern, Slot, SymBlockMatrix, check_csr_symmetric, detect_block_size, is_block_pattern,
};
pub use mtx::{
    MatrixMarket, ReadOptions, read_matrix_market, read_matrix_market_file,
    read_matrix_market_file_with, read_matrix_market_with, write_matrix_market,
    write_vector_market,
};
pub use operator::{LinearOperator, MatrixFree};
pub use pcg_matrix::{PcgMatrix, nullspace_block_size};
pub use power::{PowerHook, PowerInfo, PowerParams, power_method};
pub use precond::{
    AMG_MAX_COARSE_SIZE, AMG_MAX_LEVELS, AMG_MAX_SWEEPS, AMG_NEAR_NULLSPACE_SHAPES, Amg,
    AmgLevelStats, AmgOptions, AmgPrecision, AmgReuse, AmgSmoother, AmgStats, AnyPreconditioner,
    BlockJacobi, Identity, IncompleteCholesky, Jacobi, PrecondKind, Preconditioner,
    PreconditionerOptions, PreconditionerSetup, Ssor, amg_takes_near_nullspace, rigid_body_modes,
};
pub use short::{AsWritten, Short};
pub use symcsr::SymCsrMatrix;
