//! The command's thread count, decided in one place: every command runs
//! inside the rayon pool built here, and the kernels of `hookean-sparse`
//! and `hookean-massspring` split their work over that pool's threads.

use crate::CliError;

/// Parses `--threads N`: a whole number from 1 to
/// [`MAX_THREADS`](crate::scene::MAX_THREADS).
pub fn parse(s: &str) -> Result<usize, String> {
    let max = crate::scene::MAX_THREADS;
    match s.parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        _ => Err(format!(
            "expected a whole number of threads from 1 to {max}, got '{s}'"
        )),
    }
}

/// Checks `RAYON_NUM_THREADS`, which rayon reads when neither `--threads`
/// nor a scene's `threads` is given: unset, `0` (all cores, rayon's
/// meaning) or a whole number from 1 to
/// [`MAX_THREADS`](crate::scene::MAX_THREADS), as `--threads`.
///
/// # Errors
/// [`CliError::Input`] naming the variable (rayon itself would ignore a
/// bad value, or spawn 10^8 threads for a typo).
pub fn check_env() -> Result<(), CliError> {
    let Some(value) = std::env::var_os("RAYON_NUM_THREADS") else {
        return Ok(());
    };
    let value = value.to_string_lossy();
    if value.trim() == "0" {
        return Ok(());
    }
    parse(value.trim()).map(|_| ()).map_err(|e| {
        CliError::Input(format!(
            "RAYON_NUM_THREADS={value}: {e} (or 0 for all cores)"
        ))
    })
}

/// Runs `f` in a rayon pool of `threads` threads; `None` means rayon's
/// default: `RAYON_NUM_THREADS` if set, else one thread per core.
///
/// # Errors
/// [`CliError::Failed`] if the operating system refuses the threads.
pub fn install<R: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> R + Send,
) -> Result<R, CliError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| CliError::Failed(format!("cannot start the worker threads: {e}")))?;
    Ok(pool.install(f))
}

/// Threads of the pool the caller runs in.
pub fn current() -> usize {
    rayon::current_num_threads()
}
