//! The `hookean` command built inside the workspace's test package, so
//! that its integration tests (tests/catalogue.rs) can run it as a process.

fn main() -> std::process::ExitCode {
    hookean_cli::main()
}
