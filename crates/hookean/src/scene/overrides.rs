//! Reading a scene: TOML text or a file, `key=value` overrides applied in order, errors with the line and column, and the whole-scene rules.

use super::*;

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
    ///     concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/drape.toml"),
    ///     &["cloth.n=16", "duration=0.1"],
    /// )?;
    /// let mut sim = scene.build()?;
    /// sim.run_until(scene.duration, |_, _| std::ops::ControlFlow::Continue(()))?;
    /// # Ok::<(), hookean::HookeanError>(())
    /// ```
    ///
    /// # Errors
    /// [`HookeanError::Io`] if it cannot be read; as [`with_overrides`](Self::with_overrides).
    pub fn from_file(path: impl AsRef<Path>, overrides: &[&str]) -> Result<Self, HookeanError> {
        let path = path.as_ref();
        // A scene is a few kilobytes: 16 MiB is far beyond any, and /dev/zero stops there.
        let text = std::fs::File::open(path)
            .map_err(|e| HookeanError::io(path, e))
            .and_then(|f| {
                hookean_sparse::text::read_capped(f, Self::MAX_FILE_BYTES).map_err(|e| match e {
                    hookean_sparse::text::TextError::Io(e) => HookeanError::io(path, e),
                    e => HookeanError::Scene {
                        file: path.display().to_string(),
                        line: e.line().unwrap_or(1),
                        column: 1,
                        message: e.to_string(),
                    },
                })
            })?;
        let mut scene = Self::with_overrides(&path.display().to_string(), &text, overrides)?;
        scene.base = path.parent().map(Path::to_path_buf);
        Ok(scene)
    }

    /// Parses a scene and applies `key=value` overrides (`cloth.n=32`,
    /// `integrator.method="fb-euler"`; the value is TOML, a bare word is
    /// taken as a string) in order, each replacing the key's value in the
    /// file. An error an override causes names that override (`--set
    /// cloth.k=1: unknown field ...`), not a position in the merged text.
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
        let scene: Scene = toml::from_str(text).map_err(|e| scene_error(file, text, &e))?;
        if overrides.is_empty() {
            scene.check().map_err(|message| HookeanError::Scene {
                file: file.to_string(),
                line: 1,
                column: 1,
                message,
            })?;
            return Ok(scene);
        }
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| scene_error(file, text, &e))?;
        let mut scene = scene;
        for o in overrides {
            let blame = |message: String| HookeanError::Override {
                file: file.to_string(),
                arg: o.to_string(),
                message,
            };
            apply_override(&mut table, o).map_err(blame)?;
            // Parsing after each override names the one that breaks the scene.
            scene = toml::Value::Table(table.clone())
                .try_into()
                .map_err(|e: toml::de::Error| blame(e.message().trim().to_string()))?;
        }
        // The model-table rule holds for the result, not each intermediate:
        // the scene after the last override breaks it.
        scene.check().map_err(|message| HookeanError::Override {
            file: file.to_string(),
            arg: overrides.last().map_or_else(String::new, |o| o.to_string()),
            message,
        })?;
        Ok(scene)
    }

    /// Whole-scene rules serde cannot express: exactly one model table, and
    /// `[solver.amg]` only with the multigrid preconditioner (`"amg"`, or
    /// `"auto"`, which picks it for large models).
    pub(super) fn check(&self) -> Result<(), String> {
        let models = [
            self.cloth.is_some(),
            self.rope.is_some(),
            self.jelly.is_some(),
            self.particle.is_some(),
            self.tutorial.is_some(),
            self.mesh.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if let (Some(_), Some(p)) = (&self.solver.amg, self.solver.preconditioner)
            && p != PrecondKind::Amg
        {
            return Err(format!(
                "solver.amg: [solver.amg] is given but solver.preconditioner is \"{p}\", not \"amg\" or \"auto\""
            ));
        }
        if self.integrator.h == StepScene::Auto && self.tutorial.is_some() {
            return Err(
                "integrator.h: \"auto\" is the stable step of a mass-spring model; a [tutorial] scene needs a number"
                    .into(),
            );
        }
        if models != 1 {
            return Err(format!(
                "a scene needs exactly one model table ([cloth], [rope], [jelly], [mesh], [particle] or [tutorial]), found {models}"
            ));
        }
        Ok(())
    }
}
