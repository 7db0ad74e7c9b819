//! The facade's sinks write what `hookean run` writes: frames at the rate
//! asked (times checked against the step grid), OBJ files that read back to
//! the simulation's positions, one CSV row per step whose energies add up,
//! and nothing existing overwritten.

use std::path::PathBuf;

use hookean::prelude::*;
use hookean::sinks::{ObjFrames, Progress, STEPS_CSV_HEADER, StepsCsv};

/// A fresh folder for one test, removed by the caller.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-sinks-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn small_cloth() -> Simulation {
    let (model, state) = cloth(&ClothParams {
        nu: 6,
        nv: 6,
        ..Default::default()
    })
    .unwrap();
    Simulation::new(model, state, SimulationOptions::default()).unwrap()
}

#[test]
fn frames_csv_and_progress_record_the_run() {
    let dir = folder("run");
    let mut sim = small_cloth();
    let mut csv = StepsCsv::new(Vec::new()).unwrap();
    let mut frames = ObjFrames::new(&dir, 10.0).unwrap();
    let mut reports = Vec::new();
    let mut progress = Progress::new(0.35, std::time::Duration::ZERO, |p| reports.push(*p));
    let summary = sim
        .run_with_sinks(0.35, &mut [&mut csv, &mut frames, &mut progress])
        .unwrap();

    // h = 0.01: frames at t = 0, 0.1, 0.2, 0.3 (to round-off of the step sum).
    let times = frames.times();
    assert_eq!(times.len(), 4, "{times:?}");
    for (k, t) in times.iter().enumerate() {
        assert!((t - 0.1 * k as f64).abs() < 1e-9, "frame {k} at {t}");
    }
    // The last frame holds the state at t = 0.3; the file reads back.
    let mesh = hookean::massspring::read_obj_file(frames.path(3)).unwrap();
    assert_eq!(mesh.positions.len(), sim.model().n_particles());
    assert_eq!(mesh.triangles.len(), sim.model().faces().len());
    assert!(!frames.path(4).exists());

    // One row per step after the header; total = kinetic + gravitational + spring.
    let text = String::from_utf8(csv.into_inner()).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(STEPS_CSV_HEADER));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), summary.stats.steps);
    for r in &rows {
        let sum = r[4] + r[5] + r[6];
        assert!((r[7] - sum).abs() <= 1e-12 * sum.abs().max(1.0), "{r:?}");
    }
    assert!((rows.last().unwrap()[0] - 0.35).abs() < 1e-12);

    // Every step reported (every = 0) plus the end, the fraction reaching 1.
    assert_eq!(reports.len(), summary.stats.steps + 1);
    assert_eq!(reports.last().unwrap().fraction(), 1.0);
    assert!(reports.windows(2).all(|w| w[0].t <= w[1].t));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sinks_never_overwrite_and_errors_name_the_file() {
    let dir = folder("exist");
    let csv_path = dir.join("steps.csv");
    std::fs::write(&csv_path, "mine").unwrap();
    let err = StepsCsv::create(&csv_path).unwrap_err();
    assert!(err.to_string().contains("steps.csv"), "{err}");
    assert!(
        std::error::Error::source(&err).is_some(),
        "the io::Error is kept"
    );
    assert_eq!(std::fs::read_to_string(&csv_path).unwrap(), "mine");

    // A frame name already taken: the run stops, the file is untouched.
    std::fs::write(dir.join("frame-0000.obj"), "mine").unwrap();
    let mut sim = small_cloth();
    let mut frames = ObjFrames::new(&dir, 10.0).unwrap();
    let err = sim.run_with_sinks(0.05, &mut [&mut frames]).unwrap_err();
    assert!(err.to_string().contains("frame-0000.obj"), "{err}");
    assert_eq!(
        std::fs::read_to_string(dir.join("frame-0000.obj")).unwrap(),
        "mine"
    );

    assert!(ObjFrames::new(&dir, 0.0).is_err());
    assert!(ObjFrames::new(dir.join("missing"), 10.0).is_err());

    // Simulation::write_obj writes (and replaces) the file it is given.
    let path = dir.join("now.obj");
    sim.write_obj(&path).unwrap();
    sim.write_obj(&path).unwrap();
    let mesh = hookean::massspring::read_obj_file(&path).unwrap();
    for (p, x) in mesh.positions.iter().zip(sim.x().chunks(3)) {
        for d in 0..3 {
            assert!((p[d] - x[d]).abs() <= 1e-6 * x[d].abs().max(1.0));
        }
    }
    let err = sim
        .write_obj(dir.join("missing").join("a.obj"))
        .unwrap_err();
    assert!(err.to_string().contains("a.obj"), "{err}");

    // From<io::Error>: `?` works in a function returning HookeanError.
    fn open(p: &std::path::Path) -> Result<std::fs::File, HookeanError> {
        Ok(std::fs::File::open(p)?)
    }
    assert!(matches!(
        open(&dir.join("missing")),
        Err(HookeanError::Io { path: None, .. })
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}
