//! Load a scene, run it, and write its OBJ frames and per-step CSV with the
//! facade's sinks (what `hookean run` writes, from a program).
//!
//! `cargo run --example scene_to_obj -- scenes/drape.toml out/example-drape`

use hookean::scene::Scene;
use hookean::sinks::{ObjFrames, Progress, StepsCsv};

fn main() -> Result<(), hookean::HookeanError> {
    let args: Vec<String> = std::env::args().collect();
    let scene_path = args.get(1).map_or("scenes/drape.toml", String::as_str);
    let base = std::path::PathBuf::from(args.get(2).map_or("out/example-drape", String::as_str));
    // A fresh folder per run (run-1, run-2, ...; `find` on 1.. always finds one).
    let fresh = |k: usize| base.join(format!("run-{k}"));
    let out = (1..).map(fresh).find(|p| !p.exists()).unwrap_or_default();
    // A smaller, shorter drape than the file's; any scene key can be overridden.
    let scene = Scene::from_file(scene_path, &["cloth.n=24", "duration=1.0"])?;
    let mut sim = scene.build()?;

    std::fs::create_dir_all(&out)?;
    let mut csv = StepsCsv::create(out.join("steps.csv"))?;
    let mut frames = ObjFrames::new(&out, 10.0)?; // 10 frames per simulated second
    let mut progress = Progress::stderr(scene.duration);
    let summary =
        sim.run_with_sinks(scene.duration, &mut [&mut csv, &mut frames, &mut progress])?;
    sim.write_obj(out.join("final.obj"))?;

    let s = summary.stats;
    println!(
        "{} steps, {} Newton and {} CG iterations in {:.2} s; {} frames in {}",
        s.num_steps,
        s.num_nonlin_solv_iters,
        s.num_lin_iters,
        summary.wall.as_secs_f64(),
        frames.times().len(),
        out.display()
    );
    Ok(())
}
