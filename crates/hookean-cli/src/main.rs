//! The `hookean` binary: see the library's documentation (`hookean_cli`).

/// Counts live heap bytes for `hookean bench`'s memory column.
#[global_allocator]
static ALLOCATOR: hookean_cli::alloc::Counting = hookean_cli::alloc::Counting;

fn main() -> std::process::ExitCode {
    hookean_cli::main()
}
