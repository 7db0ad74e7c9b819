//! Runs a scene file to a time and prints the positions, one particle per
//! line, each coordinate in Rust's shortest round-trip form (the exact
//! `f64`): the Rust API's answer that the Python package's
//! `Scene.from_file(...).build().run_until(t)` is compared with bit for bit.
//!
//! ```sh
//! cargo run -p hookean --example scene_positions -- scenes/drape.toml 0.1 cloth.n=8
//! ```

use std::io::Write;
use std::process::ExitCode;

use hookean::scene::Scene;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(path), Some(t_end)) = (args.first(), args.get(1)) else {
        eprintln!("usage: scene_positions SCENE T_END [KEY=VALUE ...]");
        return ExitCode::from(2);
    };
    let Ok(t_end) = t_end.parse::<f64>() else {
        eprintln!("T_END: expected a number of seconds, got {t_end}");
        return ExitCode::from(2);
    };
    let overrides: Vec<&str> = args[2..].iter().map(String::as_str).collect();
    let run = Scene::from_file(path, &overrides).and_then(|scene| {
        let mut sim = scene.build()?;
        sim.run_until(t_end)?;
        Ok(sim)
    });
    match run {
        Ok(sim) => {
            let mut out = std::io::BufWriter::new(std::io::stdout().lock());
            let written = sim
                .x()
                .chunks_exact(3)
                .try_for_each(|p| writeln!(out, "{:?} {:?} {:?}", p[0], p[1], p[2]))
                .and_then(|()| out.flush());
            match written {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("error: writing the positions: {e}");
                    ExitCode::from(1)
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
