//! Checkpoints of every engine (issue 41, docs/OUTPUTS.md "Checkpoint and
//! resume"): a simulation saved between two steps
//! ([`Simulation::save_state`]) and restored into one built from the same
//! scene continues bit for bit: after both run on, the same positions,
//! velocities and counters as the run that was never interrupted. Each
//! case checks that the record holds the state it is about (a kept
//! Jacobian, a factor key, a history of order > 1), and one case shows
//! that dropping a kept Jacobian from the record changes the continuation,
//! so the comparison can fail.

use std::path::Path;

use hookean::ode::OdeError;
use hookean::scene::Scene;
use hookean::{HookeanError, Simulation, StateRecord};

/// `scene` (a path from the repository root) with `cloth.n=8` and `overrides`.
fn build(scene: &str, overrides: &[&str]) -> Simulation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(scene);
    let mut all = vec!["cloth.n=8"];
    all.extend_from_slice(overrides);
    Scene::from_file(&path, &all).unwrap().build().unwrap()
}

/// Positions, velocities and the step, Newton, linear-iteration and
/// Jacobian counters of a simulation.
fn outcome(sim: &Simulation) -> (Vec<f64>, Vec<f64>, [usize; 5]) {
    let s = sim.stats();
    (
        sim.x().to_vec(),
        sim.v().to_vec(),
        [
            s.num_steps,
            s.num_nonlin_solv_iters,
            s.num_lin_iters,
            s.num_jac_evals,
            s.num_lin_solv_setups,
        ],
    )
}

/// A fresh build of the scene restored from `record`, run to `t_end`.
fn resumed(scene: &str, overrides: &[&str], record: &StateRecord, t_end: f64) -> Simulation {
    let mut b = build(scene, overrides);
    b.restore_state(record).unwrap();
    b.run_until(t_end).unwrap();
    b
}

/// Runs the scene to `t_save`, saves it, runs it on to `t_end`; a fresh
/// build restored from the record and run to `t_end` must end bit for bit
/// where it did. Returns the record.
fn interrupted(scene: &str, overrides: &[&str], t_save: f64, t_end: f64) -> StateRecord {
    let mut a = build(scene, overrides);
    a.run_until(t_save).unwrap();
    let mut record = StateRecord::default();
    a.save_state(&mut record).unwrap();
    a.run_until(t_end).unwrap();
    let b = resumed(scene, overrides, &record, t_end);
    assert_eq!(a.t(), b.t());
    let (ra, rb) = (outcome(&a), outcome(&b));
    assert!(ra.0 == rb.0, "{overrides:?}: positions differ");
    assert!(ra.1 == rb.1, "{overrides:?}: velocities differ");
    assert_eq!(ra.2, rb.2, "{overrides:?}: counters differ");
    record
}

fn entry<'a>(record: &'a StateRecord, name: &str) -> &'a [f64] {
    record.get(name).unwrap()
}

const DRAPE: &str = "scenes/drape.toml";

#[test]
fn simplified_newton_resumes_with_its_kept_jacobian() {
    let sets = ["solver.newton=simplified"];
    // The simplified variant keeps its Jacobian over every other 5-step
    // stretch of this drape; it is kept at t = 0.35 s.
    let record = interrupted(DRAPE, &sets, 0.35, 0.6);
    // The Newton matrix kept across the checkpoint: saved (9 numbers per block).
    assert_eq!(entry(&record, "sys.newton")[3], 1.0, "a kept Jacobian");
    assert!(!entry(&record, "sys.newton.kept").is_empty());

    // Without it the resumed run evaluates a new one: other iterations, other bits.
    let mut dropped = record.clone();
    let mut newton = entry(&record, "sys.newton").to_vec();
    newton[3] = 0.0;
    dropped.put("sys.newton", &newton);
    dropped.put("sys.newton.kept", &[]);
    let mut a = build(DRAPE, &sets);
    a.run_until(0.6).unwrap();
    let b = resumed(DRAPE, &sets, &dropped, 0.6);
    let (ra, rb) = (outcome(&a), outcome(&b));
    assert!(ra.2 != rb.2, "other counters: {:?}", ra.2);
    assert!(ra.0 != rb.0, "the kept Jacobian makes a difference");
}

#[test]
fn simplified_newton_with_the_multigrid_resumes() {
    let sets = ["solver.newton=simplified", "solver.preconditioner=amg"];
    // After the first step the kept matrix is the one the hierarchy was
    // built from; later it was refilled with it.
    let mut refilled = Vec::new();
    for t_save in [0.01, 0.05, 0.35] {
        let record = interrupted(DRAPE, &sets, t_save, 0.5);
        assert_eq!(
            entry(&record, "sys.newton")[3],
            1.0,
            "{t_save}: a kept Jacobian"
        );
        assert!(!entry(&record, "sys.amg.built_from").is_empty());
        refilled.push(record.flag("sys.amg.refilled").unwrap());
    }
    assert_eq!(refilled, [false, true, true]);
}

#[test]
fn inexact_simplified_newton_on_eq_50_resumes() {
    for pc in ["mic0", "amg"] {
        let pc = format!("solver.preconditioner={pc}");
        let sets = ["solver.newton=inexact-simplified", pc.as_str()];
        let record = interrupted(DRAPE, &sets, 0.3, 0.6);
        // Eq. 50's path built, its matrix kept (rebuilt from gh, not saved).
        assert_eq!(entry(&record, "sys.lin")[0], 1.0, "{pc}");
        assert!(entry(&record, "sys.lin")[1] > 0.0, "{pc}: its gh");
        assert_eq!(entry(&record, "sys.lin.newton")[3], 1.0, "{pc}: kept");
    }
}

#[test]
fn imex_resumes_with_its_factor_rebuilt() {
    let record = interrupted(DRAPE, &["integrator.method=imex"], 0.3, 0.6);
    // [factored, h, revision, the two pinned corners].
    let imex = entry(&record, "sys.imex");
    assert_eq!(imex.len(), 5, "{imex:?}");
    assert_eq!(&imex[..2], &[1.0, 0.01]);
}

#[test]
fn the_variable_order_bdf_resumes() {
    for pc in ["mic0", "amg"] {
        let pc = format!("solver.preconditioner={pc}");
        let sets = ["integrator.method=bdf", pc.as_str()];
        let record = interrupted(DRAPE, &sets, 0.3, 0.6);
        let hist = entry(&record, "bdf.hist");
        assert_eq!(hist[1], 2.0, "{pc}: order 2 (max_order) by t = 0.3 s");
        assert_eq!(hist.len(), 3 + 5 * 2 * 3 * 64, "{pc}: D_0..D_4");
        assert_eq!(entry(&record, "bdf.corrector.newton")[3], 1.0, "{pc}: kept");
        assert!(!entry(&record, "bdf.corrector.jacobians").is_empty());
    }
}

#[test]
fn the_velocity_filter_resumes() {
    // FB Euler (the scene's), and Verlet, whose next step reuses the
    // acceleration of the last one.
    for method in ["fb-euler", "verlet"] {
        let method = format!("integrator.method={method}");
        let sets = ["duration=0.2", method.as_str()];
        let record = interrupted("scenes/drape-filtered.toml", &sets, 0.05, 0.1);
        assert!(record.count("filter.applications").unwrap() > 0, "{method}");
    }
}

#[test]
fn a_multigrid_that_keeps_its_hierarchy_resumes() {
    // Inexact Newton sets the multigrid up at every iteration; "keep"
    // leaves the hierarchy of its last refill for 3 of them.
    let sets = [
        "solver.preconditioner=amg",
        "solver.amg.reuse=keep",
        "solver.amg.keep_updates=3",
    ];
    let mut kept_then = Vec::new();
    for t_save in [0.1, 0.2, 0.3] {
        let record = interrupted(DRAPE, &sets, t_save, 0.4);
        assert!(!entry(&record, "sys.amg.built_from").is_empty());
        let refilled = !entry(&record, "sys.amg.refilled_from").is_empty();
        kept_then.push((refilled, record.count("sys.amg.kept_in_a_row").unwrap()));
    }
    assert!(
        kept_then
            .iter()
            .any(|&(refilled, kept)| refilled && kept > 0),
        "a checkpoint between a refill and the next: {kept_then:?}"
    );
    // With the simplified Newton's kept Jacobian too.
    interrupted(
        DRAPE,
        &["solver.newton=simplified", sets[0], sets[1]],
        0.3,
        0.5,
    );
}

#[test]
fn a_multigrid_with_eigenvector_estimates_is_refused_naming_the_key() {
    let sim = build(
        DRAPE,
        &[
            "solver.preconditioner=amg",
            "solver.amg.refill_power_iterations=2",
        ],
    );
    match sim.save_state(&mut StateRecord::default()) {
        Err(HookeanError::Ode(e @ OdeError::NoCheckpoint { .. })) => {
            assert!(
                e.to_string().contains("solver.amg.refill_power_iterations"),
                "{e}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_fixed_and_variable_step_multistep_methods_resume() {
    // Their history (and BDF2's slopes) is saved; implicit Euler's is not.
    for (method, history) in [
        ("bdf3", true),
        ("bdf2-variable", true),
        ("implicit-euler", false),
    ] {
        let set = format!("integrator.method={method}");
        let record = interrupted(DRAPE, &[set.as_str()], 0.3, 0.5);
        assert_eq!(record.contains("core.hist.0"), history, "{method}");
        let slopes = entry(&record, "core.f_n").len();
        assert_eq!(slopes > 0, method == "bdf2-variable", "{method}");
    }
}
