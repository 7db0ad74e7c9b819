//! Scene files (TOML): which model to build, how to integrate it, for how
//! long, and what to write.
//!
//! A scene has exactly one model table — `[cloth]`, `[rope]`, `[jelly]`,
//! `[mesh]` (a model from an OBJ file) or `[particle]` (the tutorial's
//! example 3) — and optional `[integrator]`, `[solver]`, `[filter]`,
//! `[model]`, `[[collider]]`, `[[pin]]`, `[contact]`, `[wind]` and `[output]` tables.
//! Every key has a documented default (the field docs below; `scenes/drape.toml`
//! spells them all out). Unknown keys, wrong types and out-of-range values
//! are errors that name the file, line and column.
//!
//! A program may add keys of its own to the files it reads, even to the
//! facade's tables, and a model table it runs itself: it names them in a
//! [`SceneExtension`] and reads with [`Scene::from_file_with`], which hands
//! them over with the same errors.
//!
//! ```
//! let scene = hookean::scene::Scene::from_toml_str("inline.toml", r#"
//!     duration = 0.05
//!     [cloth]
//!     n = 8
//! "#)?;
//! let mut sim = scene.build()?;
//! sim.run_until(scene.duration)?;
//! # Ok::<(), hookean::HookeanError>(())
//! ```

// A parser of user files: no panic on any input (tests/fuzz_scene.rs).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

use std::path::Path;

use hookean_filter::{FilterCoupling, FilterOptions, Form, Kernel};
use hookean_massspring::{
    BlockParams, ClothParams, ClothPins, Collider, Friction, MeshCollider, MeshParams,
    ModelOptions, RigidMotion, RopeParams, SelfCollision, SpringDamping, SpringMaterial,
};
use hookean_ode::{ForcingTerm, Method, NewtonMethod, SolverOptions, StepControl};
use hookean_sparse::{
    AmgOptions, AmgPrecision, AmgReuse, AmgSmoother, NegativeCurvature, PrecondKind,
    PreconditionerOptions,
};
use serde::Deserialize;
use serde::de::{Deserializer, Error as _};

use crate::error::HookeanError;
use crate::simulation::{Simulation, SimulationOptions};

mod build;
mod model;
mod output;
mod overrides;
mod pins;
mod solver;
mod validate;

pub use model::*;
pub use output::*;
pub use overrides::SceneExtension;
pub use pins::{InterpolationScene, KeyScene, PinGroupScene};
pub use solver::*;
use validate::*;

/// From this many particles on, `preconditioner = "auto"` takes AMG
/// instead of MIC(0). With the f32 hierarchy (issue 25, docs/PERFORMANCE.md)
/// AMG is the faster from 48 x 48 on (5 s drape, MIC(0) against AMG: 32 x 32
/// 0.65 s against 1.76 s, 40 x 40 a tie, 48 x 48 1.61 s against 1.31 s,
/// 64 x 64 3.08 s against 2.56 s), but the rule stays above the 64 x 64
/// reference drape: its inexact Newton (PCG to 1%) gives a swing that
/// depends on the preconditioner, 12.7% apart in total energy at t = 5 s
/// with AMG (f32 or f64 alike), so that drape keeps MIC(0) and its figures.
/// The rule itself is the library's [`PrecondKind::auto_for_blocks`].
pub const AUTO_AMG_PARTICLES: usize = PrecondKind::AUTO_AMG_BLOCKS;

/// Every key of the facade's scene tables with its units and default:
/// generated from the field docs below by `scripts/scene-keys.py` (a test
/// checks that it names every key).
pub const KEYS: &str = include_str!("../scene_keys.txt");

/// A scene: one model, how to integrate it, for how long, what to write.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Simulated seconds. Range (0, inf). Default 5.
    #[serde(default = "d_duration", deserialize_with = "positive")]
    pub duration: f64,
    /// The cloth grid model.
    pub cloth: Option<ClothScene>,
    /// The rope model.
    pub rope: Option<RopeScene>,
    /// The 3D lattice ("jelly block").
    pub jelly: Option<JellyScene>,
    /// The tutorial's example 3: one particle on a spring to the origin.
    pub particle: Option<ParticleScene>,
    /// A cloth (or any surface) from a triangle mesh in an OBJ file.
    pub mesh: Option<MeshScene>,
    /// Damping model, air friction and gravity.
    #[serde(default)]
    pub model: ModelScene,
    /// The time integrator.
    #[serde(default)]
    pub integrator: IntegratorScene,
    /// Newton and PCG.
    #[serde(default)]
    pub solver: SolverScene,
    /// The velocity filter (explicit methods only).
    pub filter: Option<FilterScene>,
    /// Planes, spheres and triangle meshes.
    #[serde(default, rename = "collider")]
    pub colliders: Vec<ColliderScene>,
    /// Pin groups as handles, moving along keyframes, hard or soft.
    #[serde(default, rename = "pin")]
    pub pins: Vec<PinGroupScene>,
    /// Cloth self-collision.
    #[serde(default)]
    pub contact: ContactScene,
    /// Wind on the model's triangles.
    pub wind: Option<WindScene>,
    /// What to write.
    #[serde(default)]
    pub output: OutputScene,
    /// The folder of the scene file: relative mesh paths start there
    /// (`None`: the working directory).
    #[serde(skip)]
    base: Option<std::path::PathBuf>,
    /// The program's model table ([`SceneExtension::MODEL_TABLES`]) the
    /// scene has instead of one of the facade's.
    #[serde(skip)]
    program_model: Option<&'static str>,
}

pub(super) fn d_duration() -> f64 {
    5.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `KEYS` (scene_keys.txt) names every field of every scene table, as
    /// the source declares them: rerun scripts/scene-keys.py after adding one.
    #[test]
    fn the_key_listing_names_every_key() {
        let src = [
            include_str!("mod.rs"),
            include_str!("model.rs"),
            include_str!("solver.rs"),
            include_str!("output.rs"),
            include_str!("pins.rs"),
        ]
        .concat();
        let tables = [
            ("Scene", ""),
            ("ClothScene", "cloth."),
            ("RopeScene", "rope."),
            ("JellyScene", "jelly."),
            ("ModelScene", "model."),
            ("IntegratorScene", "integrator."),
            ("SolverScene", "solver."),
            ("AmgScene", "solver.amg."),
            ("FilterScene", "filter."),
            ("OutputScene", "output."),
            ("MeshScene", "mesh."),
            ("ContactScene", "contact."),
            ("WindScene", "wind."),
            ("PinGroupScene", "pin."),
            ("KeyScene", "pin.keys."),
        ];
        let mut count = 0;
        for (name, prefix) in tables {
            let start = src.find(&format!("pub struct {name} {{")).unwrap();
            let body = &src[start..start + src[start..].find("\n}").unwrap()];
            let mut rename = None;
            for line in body.lines().skip(1).map(str::trim) {
                if line.starts_with("#[serde(") && line.contains("rename = \"") {
                    let r = line.split("rename = \"").nth(1).unwrap();
                    rename = Some(r[..r.find('"').unwrap()].to_string());
                } else if let Some(field) = line.strip_prefix("pub ") {
                    let field = rename
                        .take()
                        .unwrap_or_else(|| field[..field.find(':').unwrap()].to_string());
                    let key = format!("  {prefix}{field}\n");
                    assert!(
                        KEYS.contains(&key),
                        "scene_keys.txt lacks {key:?}: run scripts/scene-keys.py"
                    );
                    count += 1;
                }
            }
        }
        assert!(count > 60, "{count} keys");
    }

    #[test]
    fn auto_preconditioner_follows_the_particle_count_and_names_win() {
        let kind = |text: &str| {
            Scene::from_toml_str("s.toml", text)
                .unwrap()
                .preconditioner()
                .kind
        };
        let side = (AUTO_AMG_PARTICLES as f64).sqrt().ceil() as usize;
        let below = format!("[cloth]\nn = {}\n", side - 1);
        let above = format!("[cloth]\nn = {side}\n");
        assert!(matches!(kind(&below), PrecondKind::Mic0 { .. }));
        assert_eq!(kind(&above), PrecondKind::Amg);
        let named = format!("{above}[solver]\npreconditioner = \"mic0\"\nmic_omega = 0.5\n");
        assert_eq!(kind(&named), PrecondKind::Mic0 { omega: 0.5 });
        let auto = format!("{below}[solver]\npreconditioner = \"auto\"\n");
        assert!(matches!(kind(&auto), PrecondKind::Mic0 { .. }));
    }

    fn err(text: &str) -> (usize, usize, String) {
        match Scene::from_toml_str("s.toml", text) {
            Err(HookeanError::Scene {
                line,
                column,
                message,
                ..
            }) => (line, column, message),
            other => panic!("expected a scene error, got {other:?}"),
        }
    }

    #[test]
    fn defaults_are_the_reference_drape() {
        let s = Scene::from_toml_str("s.toml", "[cloth]\n").unwrap();
        let c = s.cloth.as_ref().unwrap();
        assert_eq!(
            (c.n, c.size, c.mass, c.stiffness, c.damping),
            (64, 1.0, 1.0, 1e4, 0.1)
        );
        assert_eq!(c.pins, PinScene::TwoCorners);
        assert_eq!(s.duration, 5.0);
        assert_eq!(s.integrator.method, Method::ImplicitEuler);
        assert_eq!(s.integrator.h, StepScene::Value(0.01));
    }

    /// A library user reads every shipped scene of the facade's models with
    /// plain `from_file`: only the tutorial scenes (a model table of the
    /// `hookean` program) need the program's keys.
    #[test]
    fn every_shipped_model_scene_is_a_facade_scene() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes");
        let mut read = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            if text.lines().any(|l| l.trim() == "[tutorial]") {
                assert!(Scene::from_file(&path, &[]).is_err(), "{}", path.display());
                continue;
            }
            Scene::from_file(&path, &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            read += 1;
        }
        assert!(read >= 8, "{read} scenes");
    }

    #[test]
    fn solver_defaults_are_the_drape_solver_and_drape_toml_spells_them_out() {
        // A bare scene solves its steps like `SimulationOptions::default()`
        // (the variable-step tolerances are the scene's own), and the
        // shipped drape.toml, which claims to spell out every default,
        // builds exactly the same options.
        let bare = Scene::from_toml_str("s.toml", "[cloth]\n").unwrap();
        let (opts, default) = (bare.simulation_options(), SimulationOptions::default());
        assert_eq!(opts.method, default.method);
        assert_eq!(opts.solver.h, default.solver.h);
        assert_eq!(opts.solver.newton, default.solver.newton);
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/drape.toml");
        let shipped = Scene::from_file(path, &[]).unwrap();
        assert_eq!(shipped.simulation_options(), bare.simulation_options());
        assert_eq!(shipped.duration, bare.duration);
    }

    #[test]
    fn unknown_keys_wrong_types_and_bad_values_name_line_and_column() {
        let (l, c, m) = err("duration = 1.0\n[cloth]\nn = 8\nstifness = 3\n");
        assert_eq!((l, c), (4, 1), "{m}");
        assert!(m.contains("stifness"), "{m}");
        let (l, c, m) = err("[cloth]\nn = \"many\"\n");
        assert_eq!((l, c), (2, 5), "{m}");
        let (l, c, m) = err("[cloth]\n  damping = -1.0\n");
        assert_eq!((l, c), (2, 13), "{m}");
        assert!(m.contains("must lie in [0, inf), got -1"), "{m}");
        let (l, _, m) = err("[cloth]\n[integrator]\nmethod = \"rk5\"\n");
        assert_eq!(l, 3, "{m}");
        let (l, _, m) = err("[rope]\n[solver]\nforcing = 1.5\n");
        assert_eq!(l, 3, "{m}");
        let (_, _, m) = err("[rope]\n[cloth]\n");
        assert!(m.contains("exactly one model"), "{m}");
        let (l, _, _) = err("[cloth]\n[[collider]]\nkind = \"cube\"\n");
        assert!(l >= 2);
    }

    #[test]
    fn solver_amg_table_sets_the_multigrid_options_and_bad_values_name_the_key() {
        let s = Scene::from_toml_str(
            "s.toml",
            "[cloth]\n[solver]\npreconditioner = \"amg\"\n[solver.amg]\nsmoother = \"ic0\"\n\
             sweeps = 2\nreuse = \"keep\"\nkeep_updates = 3\n",
        )
        .unwrap();
        let linear = s.simulation_options().solver.linear;
        let precond = linear.preconditioner;
        assert_eq!(precond.kind, PrecondKind::Amg);
        assert_eq!(precond.amg.smoother, AmgSmoother::BlockIc0);
        assert_eq!(precond.amg.sweeps, 2);
        assert_eq!(precond.amg.reuse, AmgReuse::Keep { updates: 3 });
        assert_eq!(precond.amg.coarse_size, AmgOptions::default().coarse_size);
        // Without the table: the library's defaults.
        let s = Scene::from_toml_str("s.toml", "[cloth]\n[solver]\npreconditioner = \"amg\"\n")
            .unwrap();
        assert_eq!(
            s.simulation_options().solver.linear.preconditioner.amg,
            AmgOptions::default()
        );
        let text = "[cloth]\n[solver]\npreconditioner = \"amg\"\n[solver.amg]\n";
        for (bad, key) in [
            ("strength_threshold = 1.5", "[0, 1)"),
            ("jacobi_weight = 2.0", "(0, 2)"),
            ("sweeps = 0", "1 to 100"),
            ("smoother = \"sor\"", "sor"),
            ("reuse = \"sometimes\"", "sometimes"),
            ("levels = 3", "levels"),
        ] {
            let (l, _, m) = err(&format!("{text}{bad}\n"));
            assert_eq!(l, 5, "{bad}: {m}");
            assert!(m.contains(key), "{bad}: {m}");
        }
        // The table needs the preconditioner it configures (or "auto",
        // the default, which picks it for large models).
        let (_, _, m) =
            err("[cloth]\n[solver]\npreconditioner = \"mic0\"\n[solver.amg]\nsweeps = 2\n");
        assert!(m.starts_with("solver.amg:"), "{m}");
        assert!(Scene::from_toml_str("s.toml", "[cloth]\n[solver.amg]\nsweeps = 2\n").is_ok());
    }

    #[test]
    fn the_filtered_newton_matrix_is_on_for_self_collision_and_off_for_a_sphere() {
        let opts = |toml: &str| {
            Scene::from_toml_str("s.toml", toml)
                .unwrap()
                .simulation_options()
                .solver
                .filter_matrix
        };
        let sphere = "[cloth]\nn = 6\n[[collider]]\nkind = \"sphere\"\ncenter = [0.0, 0.0, -1.0]\nradius = 0.5\n";
        assert!(!opts(sphere));
        assert!(opts("[cloth]\nn = 6\n[contact]\nself_collision = true\n"));
        assert!(!opts(
            "[cloth]\nn = 6\n[contact]\nself_collision = true\n[solver]\nfilter_matrix = false\n"
        ));
        assert!(opts(&format!("{sphere}[solver]\nfilter_matrix = true\n")));
    }

    #[test]
    fn step_auto_and_filter_coupling_are_scene_keys() {
        let s = Scene::from_toml_str(
            "s.toml",
            "[cloth]\nn = 6\n[integrator]\nmethod = \"fb-euler\"\nh = \"auto\"\n[filter]\ncoupling = \"velocity\"\n",
        )
        .unwrap();
        assert_eq!(s.integrator.h, StepScene::Auto);
        assert_eq!(s.integrator.h_safety, 0.8);
        let o = s.simulation_options();
        assert_eq!(o.filter_coupling, FilterCoupling::VelocityOnly);
        // The built step: 0.8 / sqrt 2 of the unfiltered eq. 11 limit for
        // the literal velocity coupling.
        let sim = s.build().unwrap();
        let (model, state) = hookean_massspring::cloth(&s.cloth_params().unwrap()).unwrap();
        let dt = model
            .stability(&state.x, &Default::default(), None)
            .unwrap()
            .dt_max;
        assert!((sim.h_next() - 0.8 * dt / 2f64.sqrt()).abs() < 1e-12 * dt);
        let d = Scene::from_toml_str("s.toml", "[cloth]\n[filter]\n").unwrap();
        assert_eq!(
            d.simulation_options().filter_coupling,
            FilterCoupling::Increment
        );

        let (l, c, m) = err("[cloth]\n[integrator]\nh = \"fast\"\n");
        assert_eq!((l, c), (3, 5), "{m}");
        assert!(m.contains("must lie in (0, inf) or be \"auto\""), "{m}");
        let (l, _, m) = err("[cloth]\n[integrator]\nh = -1.0\n");
        assert_eq!(l, 3, "{m}");
        let (l, _, m) = err("[cloth]\n[integrator]\nh_safety = 1.5\n");
        assert_eq!(l, 3, "{m}");
        let (l, _, m) = err("[cloth]\n[filter]\ncoupling = \"force\"\n");
        assert_eq!(l, 3, "{m}");
        assert!(m.contains("increment"), "{m}");
        // An implicit method has no explicit stable step.
        let implicit =
            Scene::from_toml_str("s.toml", "[cloth]\nn = 4\n[integrator]\nh = \"auto\"\n").unwrap();
        match implicit.build() {
            Err(e @ HookeanError::InvalidOption { .. }) => {
                let m = e.to_string();
                assert!(
                    m.contains("integrator.h") && m.contains("implicit-euler"),
                    "{m}"
                );
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("auto with implicit Euler was accepted"),
        }
    }

    /// A program's keys are split off with their positions and the facade
    /// refuses them without it; a program's model table counts as the one.
    #[test]
    fn a_programs_keys_are_its_own() {
        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Program {
            #[serde(default)]
            level: u8,
            #[serde(default)]
            output: toml::Table,
            ode: Option<toml::Table>,
        }
        impl SceneExtension for Program {
            const KEYS: &'static [&'static str] = &["level", "output.title", "ode"];
            const MODEL_TABLES: &'static [&'static str] = &["ode"];
        }
        let text = "level = 3\n[cloth]\nn = 4\n[output]\nframe_rate = 2.0\ntitle = \"t\"\n";
        let (s, p) =
            Scene::parse_with::<Program>("s.toml", text, &["output.frame_rate=4.0"]).unwrap();
        assert_eq!((s.output.frame_rate, p.level, p.ode), (4.0, 3, None));
        assert_eq!(p.output["title"].as_str(), Some("t"));
        assert_eq!(err(text).0, 1);
        match Scene::parse_with::<Program>("s.toml", "level = 300\n[cloth]\n", &[]) {
            Err(HookeanError::Scene { line, column, .. }) => assert_eq!((line, column), (1, 9)),
            other => panic!("{other:?}"),
        }
        let (s, p) = Scene::parse_with::<Program>("s.toml", "[ode]\n", &[]).unwrap();
        assert_eq!(p.ode, Some(toml::Table::new()));
        assert_eq!(s.particle_count(), (Some(1), "ode"));
        assert!(matches!(s.build(), Err(HookeanError::InvalidOption { .. })));
        // The memory estimate still refuses such a scene first, naming its table.
        assert!(matches!(
            s.build_within(0),
            Err(HookeanError::TooLarge { key: "ode", .. })
        ));
        for (text, message) in [
            (
                "[ode]\n[rope]\n",
                "([cloth], [rope], [jelly], [mesh], [particle] or [ode]), found 2",
            ),
            (
                "[ode]\n[integrator]\nh = \"auto\"\n",
                "a [ode] scene needs a number",
            ),
        ] {
            let e = Scene::parse_with::<Program>("s.toml", text, &[]).unwrap_err();
            assert!(e.to_string().contains(message), "{e}");
        }
        let (_, _, m) = err("[rope]\n[cloth]\n");
        assert!(
            m.contains("([cloth], [rope], [jelly], [mesh] or [particle]), found 2"),
            "{m}"
        );
    }

    #[test]
    fn overrides_change_values_and_are_checked() {
        let s = Scene::with_overrides(
            "s.toml",
            "[cloth]\nn = 8\n",
            &["cloth.n=5", "integrator.method=fb-euler"],
        )
        .unwrap();
        assert_eq!(s.cloth.unwrap().n, 5);
        assert_eq!(s.integrator.method, Method::FbEuler);
        // The error names the override that broke the scene, not a
        // position in a merged text.
        let overrides = ["cloth.n=4", "cloth.n=1", "cloth.n=3"];
        match Scene::with_overrides("s.toml", "[cloth]\n", &overrides) {
            Err(e @ HookeanError::Override { .. }) => {
                let m = e.to_string();
                assert!(m.starts_with("s.toml: override cloth.n=1: "), "{m}");
                assert!(m.contains("at least 2"), "{m}");
            }
            other => panic!("{other:?}"),
        }
        match Scene::with_overrides("s.toml", "[cloth]\n", &["cloth.n"]) {
            Err(HookeanError::Override { arg, message, .. }) => {
                assert_eq!(arg, "cloth.n");
                assert!(message.contains("key=value"), "{message}");
            }
            other => panic!("{other:?}"),
        }
    }
}
