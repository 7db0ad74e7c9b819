//! The scene keys of the `hookean` program, beside the facade's: the size
//! of `final.png`, the thread count and the tutorial's scalar examples.
//! They are read with the facade's scene by `Scene::from_file_with`, so a
//! scene file holds both kinds and every error names its file, line and
//! column (or the `--set` that broke the scene) either way.

use hookean::scene::{Scene, SceneExtension, finite};
use serde::Deserialize;
use serde::de::{Deserializer, Error as _};

use crate::CliError;

/// Every scene key with its units and default, the facade's and the
/// program's, as `hookean scene-keys` prints it: generated from the field
/// docs of both by `scripts/scene-keys.py` (a test checks that it names
/// every key).
pub const KEYS: &str = include_str!("scene_keys.txt");

/// The most worker threads a scene or `--threads` may ask for (a typo of
/// 10^8 threads would otherwise spawn until the system refuses).
pub const MAX_THREADS: usize = 1024;

/// Largest picture side, in pixels.
pub const MAX_PIXELS: usize = 16_384;

/// The program's keys of a scene.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramKeys {
    /// The tutorial's examples 1 and 2: scalar ODEs (not mass-spring models),
    /// integrated as first-order systems by `hookean run`.
    pub tutorial: Option<TutorialScene>,
    /// What to write.
    #[serde(default)]
    pub output: PictureScene,
    /// Worker threads of the kernels (rayon) when `hookean run` is not
    /// given `--threads`. Range 1 to 1024. Default: `RAYON_NUM_THREADS`,
    /// else all cores.
    /// Results are bitwise reproducible for a given thread count.
    #[serde(default, deserialize_with = "threads")]
    pub threads: Option<usize>,
}

impl SceneExtension for ProgramKeys {
    const KEYS: &'static [&'static str] = &[
        "tutorial",
        "output.width",
        "output.height",
        "output.checkpoint_every",
        "threads",
    ];
    const MODEL_TABLES: &'static [&'static str] = &["tutorial"];
}

/// `[output]`: the program's keys of the table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PictureScene {
    /// Width of `final.png` in pixels. Range 1 to 16384. Default 800.
    #[serde(default = "d_width", deserialize_with = "pixels")]
    pub width: usize,
    /// Height of `final.png` in pixels. Range 1 to 16384. Default 600.
    #[serde(default = "d_height", deserialize_with = "pixels")]
    pub height: usize,
    /// Simulated seconds (s) between checkpoints: `hookean run` writes the
    /// run's whole state to checkpoint.bin in the run folder (written
    /// aside and renamed into place, so a kill mid-write leaves the
    /// earlier checkpoint), and `hookean run SCENE --resume RUN_FOLDER`
    /// continues from it, bit for bit (docs/OUTPUTS.md, "Checkpoint and
    /// resume"). With this key, SIGINT and SIGTERM stop the run after its
    /// step with a checkpoint too. Range (0, inf). Default: none.
    #[serde(default, deserialize_with = "seconds")]
    pub checkpoint_every: Option<f64>,
}

impl Default for PictureScene {
    fn default() -> Self {
        Self {
            width: d_width(),
            height: d_height(),
            checkpoint_every: None,
        }
    }
}

/// `[tutorial]`: the tutorial's example 1 (`y' = lambda y`, `y(0) = 1`) or
/// example 2 (`y'' = lambda/2 y + lambda y'` with `lambda = -5`, `y(0) = 0`,
/// `y'(0) = 1`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TutorialScene {
    /// 1 or 2. Range 1 to 2.
    #[serde(deserialize_with = "example_number")]
    pub example: u8,
    /// `lambda` of example 1 (example 2 has its own). Range: any finite number. Default -15.
    #[serde(default = "d_lambda", deserialize_with = "finite")]
    pub lambda: f64,
}

fn d_width() -> usize {
    800
}
fn d_height() -> usize {
    600
}
fn d_lambda() -> f64 {
    -15.0
}

fn threads<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    let n = usize::deserialize(d)?;
    if n < 1 {
        return Err(D::Error::custom("must be at least 1"));
    }
    if n > MAX_THREADS {
        return Err(D::Error::custom(format!(
            "at most {MAX_THREADS} threads, got {n}"
        )));
    }
    Ok(Some(n))
}

fn pixels<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if (1..=MAX_PIXELS).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must lie in 1 to {MAX_PIXELS} pixels, got {v}"
        )))
    }
}

fn seconds<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v.is_finite() {
        Ok(Some(v))
    } else {
        Err(D::Error::custom(format!(
            "must be a finite number of seconds above 0, got {v:?}"
        )))
    }
}

fn example_number<'de, D: Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    let v = u8::deserialize(d)?;
    if v == 1 || v == 2 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "the tutorial scenes are examples 1 and 2 (example 3 is [particle]), got {v:?}"
        )))
    }
}

/// Reads a scene file with the command's `--set` overrides; errors are bad
/// input (exit 2), an override's named as the `--set` the user typed.
pub(crate) fn read_scene(
    path: &std::path::Path,
    set: &[String],
) -> Result<(Scene, ProgramKeys), CliError> {
    let set: Vec<&str> = set.iter().map(String::as_str).collect();
    Scene::from_file_with::<ProgramKeys>(path, &set).map_err(|e| match e {
        hookean::HookeanError::Override { file, arg, message } => {
            CliError::Input(format!("{file}: --set {arg}: {message}"))
        }
        e => CliError::Input(e.to_string()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, set: &[&str]) -> Result<(Scene, ProgramKeys), String> {
        Scene::parse_with::<ProgramKeys>("s.toml", text, set).map_err(|e| e.to_string())
    }

    /// The listing holds every key of the facade's (its own listing, line
    /// for line) and every field of the program's tables.
    #[test]
    fn the_key_listing_names_every_key_of_both() {
        for line in hookean::scene::KEYS.lines().filter(|l| l.starts_with("  ")) {
            if !line.starts_with("   ") {
                assert!(
                    KEYS.contains(&format!("{line}\n")),
                    "{line:?}: run scripts/scene-keys.py"
                );
            }
        }
        for key in ProgramKeys::KEYS {
            assert!(
                KEYS.contains(&format!("\n  {key}\n")),
                "{key}: run scripts/scene-keys.py"
            );
        }
        for field in ["example", "lambda"] {
            assert!(KEYS.contains(&format!("\n  tutorial.{field}\n")));
        }
        let src = include_str!("scene.rs");
        let fields = src.matches("\n    pub ").count();
        // tutorial, output, threads; width, height, checkpoint_every; example, lambda.
        assert_eq!(fields, 8, "a new program key: list it in KEYS above");
    }

    /// Each program key at the ends of its documented range (the listing's
    /// "Range" text, checked here word for word): accepted at them, refused
    /// just outside naming the `--set`.
    #[test]
    fn program_keys_hold_their_documented_ranges() {
        for (key, range, scene, inside, outside) in [
            (
                "threads",
                "Range 1 to 1024.",
                "[cloth]\n",
                &["1", "1024"][..],
                &["0", "1025"][..],
            ),
            (
                "output.width",
                "Range 1 to 16384.",
                "[cloth]\n",
                &["1", "16384"],
                &["0", "16385"],
            ),
            (
                "output.height",
                "Range 1 to 16384.",
                "[cloth]\n",
                &["1", "16384"],
                &["0", "16385"],
            ),
            (
                "output.checkpoint_every",
                "Range (0, inf).",
                "[cloth]\n",
                &["1e-300", "1e300"],
                &["0", "-1", "nan", "inf"],
            ),
            (
                "tutorial.example",
                "Range 1 to 2.",
                "[tutorial]\nexample = 1\n",
                &["1", "2"],
                &["0", "3"],
            ),
            (
                "tutorial.lambda",
                "Range: any finite number.",
                "[tutorial]\nexample = 1\n",
                &["-1e308", "1e308"],
                &["inf", "nan"],
            ),
        ] {
            let doc = KEYS.split(&format!("\n  {key}\n")).nth(1).unwrap();
            let doc: Vec<&str> = doc
                .lines()
                .take_while(|l| l.starts_with("      "))
                .flat_map(str::split_whitespace)
                .collect();
            let doc = doc.join(" ");
            assert!(doc.contains(range), "{key}: {doc}");
            for v in inside {
                assert!(parse(scene, &[&format!("{key}={v}")]).is_ok(), "{key}={v}");
            }
            for v in outside {
                let set = format!("{key}={v}");
                let m = parse(scene, &[&set]).unwrap_err();
                assert!(m.contains(&set), "{set}: {m}");
            }
        }
    }

    /// A program key in the file keeps the facade's errors: line and column
    /// of the value, and the whole-scene rules count `[tutorial]`.
    #[test]
    fn program_keys_are_read_beside_the_facades_with_positions() {
        let (scene, program) = parse(
            "threads = 3\n[cloth]\nn = 4\n[output]\nframe_rate = 5.0\nwidth = 40\n",
            &["output.height=30"],
        )
        .unwrap();
        assert_eq!(scene.cloth.as_ref().map(|c| c.n), Some(4));
        assert_eq!(scene.output.frame_rate, 5.0);
        assert_eq!((program.output.width, program.output.height), (40, 30));
        assert_eq!(program.threads, Some(3));
        let m = parse("[cloth]\n[output]\nwidth = 0\n", &[]).unwrap_err();
        assert!(
            m.starts_with("s.toml:3:9: must lie in 1 to 16384 pixels"),
            "{m}"
        );
        let m = parse("[cloth]\n[tutorial]\nexample = 1\n", &[]).unwrap_err();
        assert!(
            m.contains("exactly one model table ([cloth], [rope], [jelly], [mesh], [particle] or [tutorial]), found 2"),
            "{m}"
        );
        let m = parse("[tutorial]\nexample = 1\n[integrator]\nh = \"auto\"\n", &[]).unwrap_err();
        assert!(m.contains("a [tutorial] scene needs a number"), "{m}");
        let (scene, program) = parse("[tutorial]\nexample = 2\n", &[]).unwrap();
        assert_eq!(program.tutorial.map(|t| t.example), Some(2));
        assert_eq!(scene.particle_count(), (Some(1), "tutorial"));
        assert!(scene.build().is_err());
        // An unknown key lists the program's keys of its table too.
        let m = parse("[cloth]\n[output]\nwidht = 3\n", &[]).unwrap_err();
        assert_eq!(
            m,
            "s.toml:3:1: unknown field `widht`, expected one of `frame_rate`, `cache`, `width`, `height`, `checkpoint_every`"
        );
        let m = parse("[cloth]\n", &["output.widht=3"]).unwrap_err();
        assert!(
            m.ends_with(
                "expected one of `frame_rate`, `cache`, `width`, `height`, `checkpoint_every`"
            ),
            "{m}"
        );
        let m = parse("duraton = 1.0\n[cloth]\n", &[]).unwrap_err();
        assert!(m.ends_with("`output`, `tutorial`, `threads`"), "{m}");
        // Without the program, its keys are unknown to the facade.
        let m = Scene::from_toml_str("s.toml", "[cloth]\n[output]\nwidth = 40\n")
            .unwrap_err()
            .to_string();
        assert!(m.starts_with("s.toml:3:1: unknown field `width`"), "{m}");
    }
}
