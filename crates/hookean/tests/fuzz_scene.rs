//! Scene files on mutated valid scenes (`hookean_testkit::fuzz`): a scene
//! or a typed error naming the file; a scene builds within a memory cap or
//! is refused; a small one steps or fails with a typed error. Never a
//! panic. A million cases: docs/RELIABILITY.md.

use hookean::HookeanError;
use hookean::scene::{Scene, SceneExtension};
use hookean_testkit::fuzz::mutate;
use proptest::prelude::*;

/// The shipped scenes.
const VALID: &[&str] = &[
    include_str!("../../../scenes/drape.toml"),
    include_str!("../../../scenes/drape-filtered.toml"),
    include_str!("../../../scenes/rope.toml"),
    include_str!("../../../scenes/jelly.toml"),
    include_str!("../../../scenes/cloth-sphere.toml"),
    include_str!("../../../scenes/tutorial1.toml"),
    include_str!("../../../scenes/tutorial3.toml"),
];

/// The keys of the `hookean` program in the shipped scenes (hookean-cli's
/// `ProgramKeys`), taken unchecked: the facade's are under test here.
#[derive(serde::Deserialize)]
#[serde(transparent)]
struct Program(toml::Table);

impl SceneExtension for Program {
    const KEYS: &'static [&'static str] = &["tutorial", "output.width", "output.height", "threads"];
    const MODEL_TABLES: &'static [&'static str] = &["tutorial"];
}

/// Parses, builds (within 64 MiB) and, for a small model, takes two steps.
fn exercise(text: &str) -> Result<(), HookeanError> {
    let (scene, program) = Scene::parse_with::<Program>("s.toml", text, &[])?;
    if program.0.contains_key("tutorial") {
        return Ok(());
    }
    let mut sim = scene.build_within(64 << 20)?;
    if sim.model().n_particles() <= 400 {
        sim.step()?;
        sim.step()?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_scenes_give_a_simulation_or_a_typed_error(file in 0..VALID.len(), seed in any::<u64>()) {
        let bytes = mutate(VALID[file].as_bytes(), seed);
        // Scenes are text: bytes that are not UTF-8 are refused before parsing.
        let Ok(text) = std::str::from_utf8(&bytes) else { return Ok(()) };
        if let Err(HookeanError::Scene { file, line, .. }) = exercise(text) {
            prop_assert_eq!(file, "s.toml");
            prop_assert!(line >= 1 && line <= text.lines().count() + 1);
        }
    }
}

#[test]
fn the_shipped_scenes_build() {
    for text in VALID {
        exercise(text).unwrap();
    }
}
