//! The memory a command may plan to use: what `--max-memory` allows, and
//! never more than the process can get (its address-space limit, `ulimit
//! -v`, and the machine's memory). Commands estimate their memory before
//! allocating and refuse above this cap, so a size that cannot fit is an
//! error naming what sets it, never an allocation that aborts.

use crate::CliError;

/// The cap of `--max-memory GIB`: at most the machine's memory (a larger
/// cap is refused: an allocation past it would abort), and lowered to the
/// process's address-space limit when one is set.
///
/// # Errors
/// [`CliError::Input`] for a value that is not in (0, the machine's memory].
pub fn cap_bytes(gib: f64) -> Result<u64, CliError> {
    let physical = physical_memory_bytes();
    let max_gib = physical as f64 / (1u64 << 30) as f64;
    if gib > 0.0 && gib <= max_gib {
        Ok(((gib * (1u64 << 30) as f64) as u64).min(address_space_limit()))
    } else {
        Err(CliError::Input(format!(
            "--max-memory must lie in (0, {max_gib:.1}] GiB (this machine's memory), got {gib:?}"
        )))
    }
}

/// The machine's memory (`MemTotal` of /proc/meminfo; 1 TiB where it
/// cannot be read).
fn physical_memory_bytes() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            let line = t.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
            kib.checked_mul(1024)
        })
        .unwrap_or(1 << 40)
}

/// The soft address-space limit of the process (`ulimit -v`), less the
/// 256 MiB the program, its libraries and thread stacks take; no limit is
/// `u64::MAX`.
fn address_space_limit() -> u64 {
    #[cfg(target_os = "linux")]
    {
        let limit = rustix::process::getrlimit(rustix::process::Resource::As);
        if let Some(bytes) = limit.current {
            return bytes.saturating_sub(256 << 20);
        }
    }
    u64::MAX
}
