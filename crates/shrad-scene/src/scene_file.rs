//! The TOML scene file (docs/scene-format.md): camera, settings and a list of objects
//! built from primitives (quad, box, sphere) or taken from glTF / OBJ files, each with a
//! material, an optional role, a rest transform and optional keyframed animation. The keys
//! are [`crate::scene_def`]'s, which Python's `load_dict` reads too; this file adds only
//! the TOML syntax: parsing, `[[object]]` / `[[lights]]` and line numbers in errors.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::scene_def::{CameraDef, EnvironmentDef, LightDef, ObjectDef, SceneBuilder, SettingsDef};
use crate::{Scene, SceneError};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileDef {
    camera: Option<CameraDef>,
    settings: Option<SettingsDef>,
    environment: Option<EnvironmentDef>,
    #[serde(default)]
    object: Vec<toml::Spanned<ObjectDef>>,
    #[serde(default)]
    lights: Vec<toml::Spanned<LightDef>>,
}

/// 1-based lines of byte offsets in `text`, counted on from the last offset asked (the
/// tables come in order: counting from the start for each made 40,000 lights take 13 s).
struct Lines<'a> {
    text: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines {
            text: text.as_bytes(),
            pos: 0,
            line: 1,
        }
    }

    /// The line of byte offset `pos`.
    fn of(&mut self, pos: usize) -> usize {
        let pos = pos.min(self.text.len());
        if pos < self.pos {
            (self.pos, self.line) = (0, 1);
        }
        self.line += self.text[self.pos..pos]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        self.pos = pos;
        self.line
    }
}

/// Read a scene file (no role inference or validation; that is [`crate::load()`]'s job).
pub(crate) fn read(path: &Path) -> Result<Scene, SceneError> {
    let canonical = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    read_nested(path, vec![canonical])
}

/// [`read`] for a file read inside the scene files `chain` (their canonical paths,
/// outermost first, this file's last).
pub(crate) fn read_nested(path: &Path, chain: Vec<PathBuf>) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let def: FileDef = toml::from_str(&text)
        .map_err(|e| SceneError::invalid(path, e.to_string().trim_end().to_string()))?;
    let base_dir = path.parent().unwrap_or(Path::new("."));
    let mut builder = SceneBuilder::nested(path.display().to_string(), base_dir, chain);
    if let Some(c) = &def.camera {
        builder
            .camera(c)
            .map_err(|m| SceneError::invalid(path, format!("[camera]: {m}")))?;
    }
    if let Some(s) = def.settings {
        builder.settings(s).map_err(|m| {
            // The file's own name for the table a `solver.KEY` message is about.
            let m = match m.strip_prefix("solver.") {
                Some(rest) => format!("[settings.solver] {rest}"),
                None => format!("[settings]: {m}"),
            };
            SceneError::invalid(path, m)
        })?;
    }
    if let Some(e) = &def.environment {
        builder
            .environment(e)
            .map_err(|m| builder.error(path, format!("[environment]: {m}")))?;
    }
    if def.object.is_empty() {
        return Err(SceneError::invalid(path, "no [[object]] in the scene file"));
    }
    let mut lines = Lines::new(&text);
    for (i, spanned) in def.object.into_iter().enumerate() {
        let line = lines.of(spanned.span().start);
        let o = spanned.into_inner();
        let label = match &o.name {
            Some(n) => format!("object {i} '{n}' (line {line})"),
            None => format!("object {i} (line {line})"),
        };
        if let Err(m) = builder.object(i, o) {
            return Err(builder.error(path, format!("{label}: {m}")));
        }
    }
    for (i, spanned) in def.lights.iter().enumerate() {
        let line = lines.of(spanned.span().start);
        builder
            .light(i, spanned.get_ref())
            .map_err(|m| SceneError::invalid(path, format!("lights {i} (line {line}): {m}")))?;
    }
    let scene = builder.finish();
    Ok(scene)
}
