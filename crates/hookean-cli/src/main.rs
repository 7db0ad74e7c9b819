//! The `hookean` binary: see the library's documentation (`hookean_cli`).

fn main() -> std::process::ExitCode {
    hookean_cli::main()
}
