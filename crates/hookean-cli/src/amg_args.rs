//! The multigrid's options as flags of `hookean solve`, `hookean bench` and
//! `hookean bench-precond` (named after pyamg's and AMGCL's), and its
//! near-nullspace from a file of vectors or of node coordinates.

use std::path::Path;

use clap::Args;
use hookean_sparse::{
    AMG_MAX_COARSE_SIZE, AMG_MAX_LEVELS, AMG_MAX_SWEEPS, AmgOptions, AmgPrecision, AmgSmoother,
    MatrixMarket, ReadOptions, read_matrix_market_file_with, rigid_body_modes,
};

use crate::CliError;

/// The options of `--precond amg` (smoothed aggregation, V-cycle).
#[derive(Debug, Clone, Args)]
pub struct AmgArgs {
    /// The smoother of `amg`: block-jacobi (damped), gauss-seidel (symmetric block Gauss-Seidel,
    /// pyamg's default) or ic0 (block IC(0)).
    #[arg(long, default_value = "block-jacobi")]
    pub amg_smoother: String,
    /// Pre- and post-smoothing steps of `amg` on every level (pyamg's `iterations`, AMGCL's
    /// `npre`/`npost`), 1 to 100.
    #[arg(long, default_value_t = 1)]
    pub amg_sweeps: usize,
    /// Strength threshold of `amg` on the finest level, halved on every coarser one (AMGCL's
    /// `eps_strong`; pyamg's symmetric `theta`), in [0, 1); 0 makes every connection strong.
    #[arg(long, default_value_t = 0.08, allow_negative_numbers = true)]
    pub amg_strength: f64,
    /// Coarsening of `amg` stops at this many unknowns (a dense Cholesky solve there; pyamg's
    /// `max_coarse`, AMGCL's `coarse_enough`), 1 to 4096.
    #[arg(long, default_value_t = 500)]
    pub amg_coarse_size: usize,
    /// At most this many levels of `amg` (pyamg's `max_levels`), 1 to 64.
    #[arg(long, default_value_t = 10)]
    pub amg_max_levels: usize,
    /// Prolongator-smoothing weight of `amg` times rho(D^-1 A) (pyamg's jacobi `omega`), in (0, 2).
    #[arg(long, default_value_t = 4.0 / 3.0, allow_negative_numbers = true)]
    pub amg_prolongation_weight: f64,
    /// Damped-Jacobi weight of `amg`'s block-jacobi smoother times rho(D^-1 A), in (0, 2).
    #[arg(long, default_value_t = 4.0 / 3.0, allow_negative_numbers = true)]
    pub amg_jacobi_weight: f64,
    /// Power-method steps of `amg` estimating rho(D^-1 A) for the weights (AMGCL's
    /// `power_iters`), 0 to 100; 0 takes Gershgorin's bound (cheaper; tight for scalar
    /// M-matrices, loose for 3x3 blocks).
    #[arg(long, default_value_t = 5)]
    pub amg_power_iterations: usize,
    /// Storage of `amg`'s hierarchy: single (f32 entries, f64 arithmetic) or double.
    #[arg(long, default_value = "single")]
    pub amg_precision: String,
}

impl AmgArgs {
    /// The library's options for `block_size` unknowns per node and the
    /// near-nullspace `near_nullspace`; a flag out of range is an error
    /// naming it.
    pub fn options(
        &self,
        block_size: usize,
        near_nullspace: Vec<Vec<f64>>,
    ) -> Result<AmgOptions, CliError> {
        let bad = |flag: &str, range: &str, value: String| {
            Err(CliError::Input(format!(
                "--{flag} must lie in {range}, got {value}"
            )))
        };
        let smoother = match self.amg_smoother.as_str() {
            "block-jacobi" => AmgSmoother::BlockJacobi,
            "gauss-seidel" => AmgSmoother::SymmetricGaussSeidel,
            "ic0" => AmgSmoother::BlockIc0,
            other => {
                return Err(CliError::Input(format!(
                    "--amg-smoother: unknown smoother '{other}' (expected block-jacobi, gauss-seidel or ic0)"
                )));
            }
        };
        let precision = match self.amg_precision.as_str() {
            "single" => AmgPrecision::Single,
            "double" => AmgPrecision::Double,
            other => {
                return Err(CliError::Input(format!(
                    "--amg-precision: unknown precision '{other}' (expected single or double)"
                )));
            }
        };
        // The library's ranges (hookean-sparse owns them), checked here to
        // name the flag.
        for (flag, value, lo, hi) in [
            ("amg-sweeps", self.amg_sweeps, 1, AMG_MAX_SWEEPS),
            (
                "amg-power-iterations",
                self.amg_power_iterations,
                0,
                AMG_MAX_SWEEPS,
            ),
            (
                "amg-coarse-size",
                self.amg_coarse_size,
                1,
                AMG_MAX_COARSE_SIZE,
            ),
            ("amg-max-levels", self.amg_max_levels, 1, AMG_MAX_LEVELS),
        ] {
            if !(lo..=hi).contains(&value) {
                return bad(flag, &format!("{lo} to {hi}"), value.to_string());
            }
        }
        // The scene keys' ranges (solver.amg.strength_threshold, .jacobi_weight,
        // .prolongation_weight; hookean::range owns them).
        for (flag, value, range) in [
            (
                "amg-strength",
                self.amg_strength,
                hookean::range::AMG_STRENGTH,
            ),
            (
                "amg-prolongation-weight",
                self.amg_prolongation_weight,
                hookean::range::AMG_WEIGHT,
            ),
            (
                "amg-jacobi-weight",
                self.amg_jacobi_weight,
                hookean::range::AMG_WEIGHT,
            ),
        ] {
            if !range.contains(value) {
                return bad(
                    flag,
                    &range.to_string(),
                    hookean_sparse::AsWritten(value).to_string(),
                );
            }
        }
        Ok(AmgOptions {
            strength_threshold: self.amg_strength,
            coarse_size: self.amg_coarse_size,
            max_levels: self.amg_max_levels,
            smoother,
            sweeps: self.amg_sweeps,
            jacobi_weight: self.amg_jacobi_weight,
            prolongation_weight: self.amg_prolongation_weight,
            power_iterations: self.amg_power_iterations,
            near_nullspace,
            block_size,
            precision,
            ..Default::default()
        })
    }
}

/// The columns of a Matrix Market file (array or coordinate), each a
/// vector; the error says what is wrong (without the file's name when the
/// reader gave it).
pub fn read_columns(path: &Path, cap: u64) -> Result<Vec<Vec<f64>>, String> {
    let opts = ReadOptions {
        max_bytes: cap,
        ..ReadOptions::default()
    };
    let m = read_matrix_market_file_with(path, &opts).map_err(|e| e.to_string())?;
    let (rows, cols) = m.shape();
    let values = match m {
        MatrixMarket::Dense { values, .. } => values,
        MatrixMarket::Sparse(a) => {
            // Dense columns of a coordinate file: bounded by the byte cap
            // before the allocation (its size line may declare any shape).
            let entries = rows
                .checked_mul(cols)
                .filter(|&e| (e as u64).saturating_mul(8) <= cap);
            let Some(entries) = entries else {
                return Err(format!(
                    "{rows} x {cols} dense columns would need more than the {cap} bytes allowed"
                ));
            };
            let mut v = vec![0.0; entries];
            for (&x, (r, c)) in a.iter() {
                v[c * rows + r] = x;
            }
            v
        }
    };
    Ok(values.chunks(rows.max(1)).map(<[f64]>::to_vec).collect())
}

/// The rigid-body modes (3 in 2D, 6 in 3D) of the nodes whose coordinates
/// are the rows of the Matrix Market file `path` (`n x d`, d = 2 or 3).
pub fn read_rigid_body_modes(path: &Path, cap: u64) -> Result<Vec<Vec<f64>>, String> {
    let columns = read_columns(path, cap)?;
    let d = columns.len();
    if !(d == 2 || d == 3) {
        return Err(format!(
            "{}: {d} columns; node coordinates have 2 (2D) or 3 (3D)",
            path.display()
        ));
    }
    let n = columns[0].len();
    let coordinates: Vec<f64> = (0..n * d).map(|k| columns[k % d][k / d]).collect();
    rigid_body_modes(&coordinates, d).map_err(|e| format!("{}: {e}", path.display()))
}
