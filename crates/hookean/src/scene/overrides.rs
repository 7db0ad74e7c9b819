//! Reading a scene: TOML text or a file, `key=value` overrides applied in order, a program's keys split off, errors with the line and column, and the whole-scene rules.

use std::borrow::Borrow;

use serde::de::DeserializeOwned;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::*;

/// The keys a program adds to the scene files it reads, beside the
/// facade's: its own tables (`"tutorial"`), top-level keys, or keys in one
/// of the facade's tables (`"output.width"`). [`Scene::from_file_with`]
/// splits them off and deserializes them into `Self` with the errors of the
/// facade's own keys (file, line and column; the override that broke the
/// scene). A scene read without a program refuses them as unknown keys.
pub trait SceneExtension: DeserializeOwned {
    /// The dotted keys the program owns (one or two parts).
    const KEYS: &'static [&'static str];
    /// Those of `KEYS` that are model tables of the program's own: a scene
    /// has exactly one model table, the facade's or one of these, and
    /// [`Scene::build`] refuses a scene whose model is the program's.
    const MODEL_TABLES: &'static [&'static str] = &[];
}

/// No program: every key is the facade's.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NoProgram {}

impl SceneExtension for NoProgram {
    const KEYS: &'static [&'static str] = &[];
}

/// 1-based line and column of a byte offset.
pub(super) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Sets `key` (dotted) of `table` to `value` for the override `key=value`.
pub(super) fn apply_override(table: &mut toml::Table, o: &str) -> Result<(), String> {
    let (key, value) = o
        .split_once('=')
        .ok_or_else(|| "not key=value".to_string())?;
    let value: toml::Value = match toml::from_str::<toml::Table>(&format!("v = {value}")) {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| toml::Value::String(value.trim().to_string())),
        Err(_) => toml::Value::String(value.trim().to_string()),
    };
    let parts: Vec<&str> = key.trim().split('.').map(str::trim).collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(format!("'{key}' is not a key (e.g. cloth.n)"));
    }
    let (last, tables) = parts.split_last().ok_or("empty key")?;
    let mut cursor = table;
    for part in tables {
        let entry = cursor
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cursor = entry
            .as_table_mut()
            .ok_or_else(|| format!("'{part}' is a value, not a table"))?;
    }
    cursor.insert(last.to_string(), value);
    Ok(())
}

pub(super) fn scene_error(file: &str, text: &str, e: &toml::de::Error) -> HookeanError {
    let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
    HookeanError::Scene {
        file: file.to_string(),
        line,
        column,
        message: e.message().trim().to_string(),
    }
}

/// A TOML value that may be a table: the parsed document's (with spans) or
/// an override's.
trait Node: Sized {
    type Key: Ord + std::hash::Hash + Borrow<str> + Clone;
    fn table(&self) -> Option<&toml::map::Map<Self::Key, Self>>;
    fn table_mut(&mut self) -> Option<&mut toml::map::Map<Self::Key, Self>>;
    /// An empty table where `self` is (its span, for the document's).
    fn empty_table_at(&self) -> Self;
}

impl Node for toml::Value {
    type Key = String;
    fn table(&self) -> Option<&toml::Table> {
        self.as_table()
    }
    fn table_mut(&mut self) -> Option<&mut toml::Table> {
        self.as_table_mut()
    }
    fn empty_table_at(&self) -> Self {
        toml::Value::Table(toml::Table::new())
    }
}

impl<'i> Node for Spanned<DeValue<'i>> {
    type Key = Spanned<toml::de::DeString<'i>>;
    fn table(&self) -> Option<&DeTable<'i>> {
        self.get_ref().as_table()
    }
    fn table_mut(&mut self) -> Option<&mut DeTable<'i>> {
        match self.get_mut() {
            DeValue::Table(t) => Some(t),
            _ => None,
        }
    }
    fn empty_table_at(&self) -> Self {
        Spanned::new(self.span(), DeValue::Table(DeTable::new()))
    }
}

/// Moves the program's `keys` (dotted, one or two parts) out of `root`
/// into a table of their own, keeping each key's and value's span.
fn split_off<V: Node>(
    root: &mut toml::map::Map<V::Key, V>,
    keys: &[&str],
) -> toml::map::Map<V::Key, V> {
    let mut program = toml::map::Map::new();
    for key in keys {
        let Some((table, leaf)) = key.split_once('.') else {
            if let Some((k, v)) = root.remove_entry(*key) {
                program.insert(k, v);
            }
            continue;
        };
        let Some((table_key, _)) = root.get_key_value(table) else {
            continue;
        };
        let table_key = table_key.clone();
        let Some(value) = root.get_mut(table) else {
            continue;
        };
        let empty = value.empty_table_at();
        let Some((k, v)) = value.table_mut().and_then(|t| t.remove_entry(leaf)) else {
            continue;
        };
        if let Some(t) = program.entry(table_key).or_insert(empty).table_mut() {
            t.insert(k, v);
        }
    }
    program
}

/// serde's message for an unknown key of the facade's part of `root`,
/// with the program's `keys` of the same table among the expected ones, as
/// if one struct read the table (the program's are listed last).
/// `None` for any other error.
fn expecting_program_keys<V: Node>(
    e: &toml::de::Error,
    root: &toml::map::Map<V::Key, V>,
    keys: &[&str],
) -> Option<String> {
    let (field, expected) = e
        .message()
        .trim()
        .strip_prefix("unknown field `")?
        .split_once("`, expected ")?;
    // The table that holds the key: the top level, or one of its tables.
    let table = if root.contains_key(field) {
        ""
    } else {
        root.iter()
            .find(|(_, v)| v.table().is_some_and(|t| t.contains_key(field)))
            .map(|(k, _)| k.borrow())?
    };
    let program = keys.iter().filter_map(|k| match k.split_once('.') {
        Some((t, leaf)) if t == table => Some(leaf),
        None if table.is_empty() => Some(*k),
        _ => None,
    });
    let mut names: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    let facade = names.len();
    names.extend(program);
    if names.len() == facade {
        return None;
    }
    // serde's wording (`serde::de::Error::unknown_field`).
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    let list = match quoted.as_slice() {
        [a, b] => format!("{a} or {b}"),
        _ => format!("one of {}", quoted.join(", ")),
    };
    Some(format!("unknown field `{field}`, expected {list}"))
}

impl Scene {
    /// Parses a scene from TOML text; `file` names it in error messages.
    ///
    /// # Errors
    /// [`HookeanError::Scene`] with the line and column of the offending
    /// key or value.
    pub fn from_toml_str(file: &str, text: &str) -> Result<Self, HookeanError> {
        Self::with_overrides(file, text, &[])
    }

    /// Reads a scene file and applies `key=value` overrides as
    /// [`with_overrides`](Self::with_overrides) does.
    ///
    /// ```
    /// use hookean::scene::Scene;
    /// let scene = Scene::from_file(
    ///     concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/cloth-sphere.toml"),
    ///     &["cloth.n=16", "duration=0.1"],
    /// )?;
    /// let mut sim = scene.build()?;
    /// sim.run_until(scene.duration)?;
    /// # Ok::<(), hookean::HookeanError>(())
    /// ```
    ///
    /// # Errors
    /// [`HookeanError::Io`] if it cannot be read; as [`with_overrides`](Self::with_overrides).
    pub fn from_file(path: impl AsRef<Path>, overrides: &[&str]) -> Result<Self, HookeanError> {
        Self::from_file_with::<NoProgram>(path, overrides).map(|(scene, _)| scene)
    }

    /// [`from_file`](Self::from_file) for a program that adds keys of its
    /// own ([`SceneExtension`]): the facade's scene and the program's keys.
    ///
    /// # Errors
    /// As [`from_file`](Self::from_file), for the program's keys too.
    pub fn from_file_with<P: SceneExtension>(
        path: impl AsRef<Path>,
        overrides: &[&str],
    ) -> Result<(Self, P), HookeanError> {
        let path = path.as_ref();
        // A scene is a few kilobytes: 16 MiB is far beyond any. Only a
        // regular file is read (a FIFO or a device is refused, not waited on).
        let text = hookean_io::read_file(path, Self::MAX_FILE_BYTES).map_err(|e| match e {
            hookean_io::TextError::Io(e) => HookeanError::io(path, e),
            e => HookeanError::Scene {
                file: path.display().to_string(),
                line: e.line().unwrap_or(1),
                column: 1,
                message: e.to_string(),
            },
        })?;
        Self::from_text_with::<P>(path, &text, overrides)
    }

    /// A scene from the text of the file `path` (read before, kept, or
    /// sent to another process), as [`from_file`](Self::from_file) would
    /// make it: `path` names it in messages and relative paths in it (mesh
    /// colliders, OBJ models) resolve against its folder.
    ///
    /// # Errors
    /// As [`with_overrides`](Self::with_overrides).
    pub fn from_text(
        path: impl AsRef<Path>,
        text: &str,
        overrides: &[&str],
    ) -> Result<Self, HookeanError> {
        Self::from_text_with::<NoProgram>(path, text, overrides).map(|(scene, _)| scene)
    }

    /// [`from_text`](Self::from_text) for a program that adds keys of its
    /// own ([`SceneExtension`]).
    ///
    /// # Errors
    /// As [`with_overrides`](Self::with_overrides), for the program's keys too.
    pub fn from_text_with<P: SceneExtension>(
        path: impl AsRef<Path>,
        text: &str,
        overrides: &[&str],
    ) -> Result<(Self, P), HookeanError> {
        let path = path.as_ref();
        let (mut scene, program) =
            Self::parse_with::<P>(&path.display().to_string(), text, overrides)?;
        scene.base = path.parent().map(Path::to_path_buf);
        Ok((scene, program))
    }

    /// Parses a scene and applies `key=value` overrides (`cloth.n=32`,
    /// `integrator.method="fb-euler"`; the value is TOML, a bare word is
    /// taken as a string) in order, each replacing the key's value in the
    /// file. An error an override causes names that override (`cloth.k=1:
    /// unknown field ...`), not a position in the merged text.
    ///
    /// # Errors
    /// As [`from_toml_str`](Self::from_toml_str) for the file itself;
    /// [`HookeanError::Override`] for an override that is not `key=value`,
    /// names a key below a value, or makes the scene invalid (the first
    /// override after which the scene no longer parses is named).
    pub fn with_overrides(
        file: &str,
        text: &str,
        overrides: &[&str],
    ) -> Result<Self, HookeanError> {
        Self::parse_with::<NoProgram>(file, text, overrides).map(|(scene, _)| scene)
    }

    /// [`with_overrides`](Self::with_overrides) for a program that adds
    /// keys of its own ([`SceneExtension`]).
    ///
    /// # Errors
    /// As [`with_overrides`](Self::with_overrides), for the program's keys too.
    pub fn parse_with<P: SceneExtension>(
        file: &str,
        text: &str,
        overrides: &[&str],
    ) -> Result<(Self, P), HookeanError> {
        let in_file = |e: toml::de::Error| scene_error(file, text, &e);
        // The file itself, with positions: the facade's keys and the program's.
        let root = DeTable::parse(text).map_err(in_file)?;
        let span = root.span();
        let mut table = root.into_inner();
        let program_table = split_off(&mut table, P::KEYS);
        let models = model_tables::<P, _>(&program_table);
        let document = |t| toml::de::Deserializer::from(Spanned::new(span.clone(), t));
        let mut scene = Scene::deserialize(document(table.clone())).map_err(|e| {
            let mut error = scene_error(file, text, &e);
            if let (HookeanError::Scene { message, .. }, Some(m)) =
                (&mut error, expecting_program_keys(&e, &table, P::KEYS))
            {
                *message = m;
            }
            error
        })?;
        let mut program = P::deserialize(document(program_table)).map_err(in_file)?;
        scene.program_model = models.first().copied();
        if overrides.is_empty() {
            scene
                .check(P::MODEL_TABLES, models.len())
                .map_err(|message| HookeanError::Scene {
                    file: file.to_string(),
                    line: 1,
                    column: 1,
                    message,
                })?;
            return Ok((scene, program));
        }
        let mut table: toml::Table = toml::from_str(text).map_err(in_file)?;
        let mut models = models;
        for o in overrides {
            let blame = |message: String| HookeanError::Override {
                file: file.to_string(),
                arg: o.to_string(),
                message,
            };
            apply_override(&mut table, o).map_err(blame)?;
            // Parsing after each override names the one that breaks the scene.
            let mut facade = table.clone();
            let program_table = split_off(&mut facade, P::KEYS);
            models = model_tables::<P, _>(&program_table);
            let message = |e: toml::de::Error| blame(e.message().trim().to_string());
            scene = toml::Value::Table(facade.clone()).try_into().map_err(|e| {
                blame(
                    expecting_program_keys(&e, &facade, P::KEYS)
                        .unwrap_or_else(|| e.message().trim().to_string()),
                )
            })?;
            program = toml::Value::Table(program_table)
                .try_into()
                .map_err(message)?;
            scene.program_model = models.first().copied();
        }
        // The model-table rule holds for the result, not each intermediate:
        // the scene after the last override breaks it.
        scene
            .check(P::MODEL_TABLES, models.len())
            .map_err(|message| HookeanError::Override {
                file: file.to_string(),
                arg: overrides.last().map_or_else(String::new, |o| o.to_string()),
                message,
            })?;
        Ok((scene, program))
    }

    /// Whole-scene rules serde cannot express: exactly one model table (the
    /// facade's, or one of a program's `program_tables`, of which the scene
    /// has `program_models`), and `[solver.amg]` only with the multigrid
    /// preconditioner (`"amg"`, or `"auto"`, which picks it for large models),
    /// and `output.cache` only with OBJ frames.
    pub(super) fn check(
        &self,
        program_tables: &[&str],
        program_models: usize,
    ) -> Result<(), String> {
        let models = [
            self.cloth.is_some(),
            self.rope.is_some(),
            self.jelly.is_some(),
            self.particle.is_some(),
            self.mesh.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count()
            + program_models;
        if let (Some(_), Some(p)) = (&self.solver.amg, self.solver.preconditioner)
            && p != PrecondKind::Amg
        {
            return Err(format!(
                "solver.amg: [solver.amg] is given but solver.preconditioner is \"{p}\", not \"amg\" or \"auto\""
            ));
        }
        if self.integrator.h == StepScene::Auto
            && let Some(table) = self.program_model
        {
            return Err(format!(
                "integrator.h: \"auto\" is the stable step of a mass-spring model; a [{table}] scene needs a number"
            ));
        }
        if let Some(cache) = self.output.cache
            && self.output.frame_rate == 0.0
        {
            return Err(format!(
                "output.cache: \"{cache}\" caches the OBJ frames, but output.frame_rate = 0 writes none; set output.frame_rate > 0"
            ));
        }
        if models != 1 {
            let names: Vec<String> = ["cloth", "rope", "jelly", "mesh", "particle"]
                .iter()
                .chain(program_tables)
                .map(|t| format!("[{t}]"))
                .collect();
            let mut names = names;
            let last = names.pop().unwrap_or_default();
            return Err(format!(
                "a scene needs exactly one model table ({} or {last}), found {models}",
                names.join(", ")
            ));
        }
        Ok(())
    }
}

/// The program's model tables present in its split-off keys.
fn model_tables<P: SceneExtension, V: Node>(
    program: &toml::map::Map<V::Key, V>,
) -> Vec<&'static str> {
    P::MODEL_TABLES
        .iter()
        .copied()
        .filter(|t| program.contains_key(*t))
        .collect()
}
