//! The `[[pin]]` tables of a scene: pin groups as handles
//! (hookean-massspring's `PinGroup`), and the one selection of vertices by
//! index or box, shared with `[mesh]`'s `pins` / `pin_box`.

use hookean_massspring::{Interpolation, Keyframe, KeyframedPath, MassSpringModel, PinGroup};

use super::*;
use crate::range;

/// `[[pin]]`: a group of vertices held at targets that move rigidly along
/// keyframes, hard (`weight = 1`) or soft, released at a time.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinGroupScene {
    /// The vertices, 0-based (a cloth's grid row by row, a mesh's `v` lines).
    #[serde(default)]
    pub vertices: Vec<usize>,
    /// Every vertex inside the box `[[x0, y0, z0], [x1, y1, z1]]` at the
    /// start (m), besides `vertices`.
    #[serde(default, rename = "box")]
    pub pin_box: Option<[[f64; 3]; 2]>,
    /// 1: hard pins; below 1: soft pins, springs of stiffness `weight *
    /// stiffness` to the targets. In [0, 1]. Default 1.
    #[serde(default = "one", deserialize_with = "pin_weight")]
    pub weight: f64,
    /// Soft pins' stiffness at weight 1 (N/m). In [0, inf). Default 1000.
    #[serde(default = "d_pin_stiffness", deserialize_with = "pin_stiffness")]
    pub stiffness: f64,
    /// The time the group lets go (s). Default: never.
    #[serde(default, deserialize_with = "pin_release")]
    pub release: Option<f64>,
    /// `"linear"` (default) or `"smooth"` (3u^2 - 2u^3 between keys).
    #[serde(default)]
    pub interpolation: InterpolationScene,
    /// The centre of the keys' rotations at the start (m). Default: the
    /// mean of the group's start positions.
    #[serde(default, deserialize_with = "pin_pivot")]
    pub pivot: Option<[f64; 3]>,
    /// The targets' path: `{ t, translation = [x, y, z], rotation = [x, y, z] }`
    /// keys, times increasing (s, m, rad: the rotation vector about the
    /// pivot). Default: none (the targets stay at the start positions).
    #[serde(default)]
    pub keys: Vec<KeyScene>,
}

/// One key of a `[[pin]]` path.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyScene {
    /// Time (s).
    #[serde(deserialize_with = "key_time")]
    pub t: f64,
    /// Translation of the targets (m). Default [0, 0, 0].
    #[serde(default, deserialize_with = "key_translation")]
    pub translation: [f64; 3],
    /// Rotation vector about the pivot (rad). Default [0, 0, 0].
    #[serde(default, deserialize_with = "key_rotation")]
    pub rotation: [f64; 3],
}

/// `interpolation` of a `[[pin]]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InterpolationScene {
    /// Linear.
    #[default]
    Linear,
    /// Smooth.
    Smooth,
}

fn d_pin_stiffness() -> f64 {
    1000.0
}

fn pin_weight<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    range::PIN_WEIGHT
        .check(v)
        .map_err(|e| D::Error::custom(format!("pin.weight: {e}")))
}

fn pin_stiffness<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    range::Range::NON_NEGATIVE
        .check(v)
        .map_err(|e| D::Error::custom(format!("pin.stiffness: {e}")))
}

fn pin_release<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = f64::deserialize(d)?;
    range::Range::FINITE
        .check(v)
        .map(Some)
        .map_err(|e| D::Error::custom(format!("pin.release: {e}")))
}

fn pin_pivot<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[f64; 3]>, D::Error> {
    finite3(d)
        .map(Some)
        .map_err(|e: D::Error| D::Error::custom(format!("pin.pivot: {e}")))
}

fn key_time<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    range::Range::FINITE
        .check(v)
        .map_err(|e| D::Error::custom(format!("keys.t: {e}")))
}

fn key_translation<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    finite3(d).map_err(|e: D::Error| D::Error::custom(format!("keys.translation: {e}")))
}

fn key_rotation<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    finite3(d).map_err(|e: D::Error| D::Error::custom(format!("keys.rotation: {e}")))
}

/// The vertices of `indices` (each checked against the model's `n`, named
/// as `key` of `table`) and, with `pin_box`, every vertex of `x` inside it:
/// the one vertex selection of `[mesh]` pins and `[[pin]]` groups.
pub(super) fn select_vertices(
    table: &str,
    key: &str,
    indices: &[usize],
    pin_box: Option<[[f64; 3]; 2]>,
    x: &[f64],
) -> Result<Vec<usize>, HookeanError> {
    let n = x.len() / 3;
    if let Some(&bad) = indices.iter().find(|&&p| p >= n) {
        return Err(HookeanError::Build {
            table: table.into(),
            message: format!("{key}: vertex {bad} does not exist ({n} vertices, numbered from 0)"),
        });
    }
    let mut out = indices.to_vec();
    if let Some([lo, hi]) = pin_box {
        out.extend(
            (0..n).filter(|&p| (0..3).all(|c| lo[c] <= x[3 * p + c] && x[3 * p + c] <= hi[c])),
        );
    }
    Ok(out)
}

/// The path through the keys of a `[[pin]]` or a `[[collider]]`: the one
/// reading of `keys` and `interpolation`; the error names the key.
pub(super) fn keyframed_path(
    keys: &[KeyScene],
    interpolation: InterpolationScene,
    pivot: [f64; 3],
) -> Result<KeyframedPath, String> {
    let keys = keys
        .iter()
        .map(|k| Keyframe {
            t: k.t,
            translation: k.translation,
            rotation: k.rotation,
        })
        .collect();
    let interpolation = match interpolation {
        InterpolationScene::Linear => Interpolation::Linear,
        InterpolationScene::Smooth => Interpolation::Smooth,
    };
    KeyframedPath::new(keys, interpolation, pivot).map_err(|e| match e {
        hookean_massspring::MassSpringError::InvalidParameter { name, message } => {
            format!("{name}: {message}")
        }
        e => format!("keys: {e}"),
    })
}

impl PinGroupScene {
    /// Adds the group (the `number`th `[[pin]]`, from 1) to `model`, its
    /// targets at rest at the start positions `x`.
    pub(super) fn add_to(
        &self,
        number: usize,
        model: &mut MassSpringModel,
        x: &[f64],
    ) -> Result<(), HookeanError> {
        let table = format!("pin {number}");
        let err = |message: String| HookeanError::Build {
            table: table.clone(),
            message,
        };
        let mut particles = select_vertices(&table, "vertices", &self.vertices, self.pin_box, x)?;
        particles.sort_unstable();
        particles.dedup();
        if particles.is_empty() {
            return Err(err(
                "no vertices: give vertices = [...] or a box that holds some".into(),
            ));
        }
        let path = if self.keys.is_empty() {
            None
        } else {
            let pivot = self.pivot.unwrap_or_else(|| {
                let mut c = [0.0; 3];
                for &p in &particles {
                    for r in 0..3 {
                        c[r] += x[3 * p + r] / particles.len() as f64;
                    }
                }
                c
            });
            Some(keyframed_path(&self.keys, self.interpolation, pivot).map_err(err)?)
        };
        let group = PinGroup {
            particles,
            weight: self.weight,
            stiffness: self.stiffness,
            path,
            release: self.release,
        };
        model
            .add_pin_group(group, x)
            .map_err(|e| err(e.to_string()))
    }
}
