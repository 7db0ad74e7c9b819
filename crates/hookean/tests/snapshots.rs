//! Snapshots of the counters users read (insta): a change in Newton or CG
//! iteration counts shows up as a reviewed diff of `tests/snapshots/`, not
//! as a surprise. Run `cargo insta review` (or set `INSTA_UPDATE=always`)
//! to accept an intended change; CI refuses unreviewed ones.
//!
//! The counts are exact for a given CPU family: the assembly and the filter
//! dispatch to AVX2 where the CPU has it, so another instruction set may
//! change a count by the last bits' influence on PCG.

use hookean::prelude::*;

#[test]
fn implicit_drape_statistics() {
    let (model, state) = cloth(&ClothParams::drape(16)).unwrap();
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    let summary = sim.run_until(0.5).unwrap();
    insta::assert_snapshot!(format!(
        "t = {}\n{:#?}",
        summary.t,
        counters(&summary.stats)
    ));
}

/// The run's counters: its statistics with the phases' wall times zeroed
/// (they differ from run to run).
fn counters(stats: &hookean::ode::Stats) -> hookean::ode::Stats {
    hookean::ode::Stats {
        phases: Default::default(),
        ..*stats
    }
}

#[test]
fn cloth_on_a_sphere_statistics() {
    // The shipped contact scene at 12 x 12 particles, through the first
    // 0.4 s of contact: about one Newton iteration per step and no retried
    // step (with newton_rtol = 1e-6 it took 812 Newton iterations and 37
    // retries here).
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cloth-sphere.toml");
    let scene = hookean::scene::Scene::from_file(&path, &["cloth.n=12", "duration=0.4"]).unwrap();
    let mut sim = scene.build().unwrap();
    let summary = sim.run_until(0.4).unwrap();
    let stats = &summary.stats;
    assert_eq!(stats.num_rejected_steps(), 0);
    assert!(
        stats.num_nonlin_solv_iters <= 3 * stats.num_steps,
        "{stats:?}"
    );
    insta::assert_snapshot!(format!("t = {}\n{:#?}", summary.t, counters(stats)));
}
