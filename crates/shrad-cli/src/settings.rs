//! A scene file's `[settings.solver]`: `solver`, `preset` and the solver's keys, the same
//! keys as `--set` (`cube_res`, or `cube-res`). Every key is checked when the scene loads
//! (an unknown one is an error naming the file and the key, with the nearest key); the
//! values are checked by the library when they are applied (`solver_args`), and a key the
//! command line sets is not read from the file.

use std::collections::BTreeMap;

use anyhow::{bail, Result};
use shrad::settings::SOLVERS;
use shrad::solver::SolverChoice;

/// Names that scene files used before the keys were the library's: an error naming the key.
const RENAMED: [(&str, &str); 4] = [
    ("objects_per_frame", "per_frame"),
    ("method", "solver"),
    ("direct_interior", "direct_on_interior"),
    ("grid", "per_axis"),
];

/// One solver key of the file.
pub struct FileKey {
    /// The key as written in the file.
    pub written: String,
    /// The library's key.
    pub key: String,
    /// The value as written.
    pub value: String,
}

/// The `[settings.solver]` of one scene file.
#[derive(Default)]
pub struct FileSettings {
    /// The scene file, for messages.
    pub source: String,
    /// `solver = ...`.
    pub solver: Option<String>,
    /// `preset = ...`.
    pub preset: Option<String>,
    /// The solver keys.
    pub keys: Vec<FileKey>,
}

/// Every key of every solver, sorted and without repeats.
fn every_key() -> Vec<&'static str> {
    let mut all: Vec<&'static str> = SOLVERS
        .iter()
        .filter_map(|s| SolverChoice::keys_of(s).ok())
        .flat_map(|keys| keys.iter().map(|k| k.name))
        .collect();
    all.sort_unstable();
    all.dedup();
    all
}

/// Check the keys of `solver` (the `[settings.solver]` table of the scene file `source`).
pub fn from_file(source: &str, solver: &BTreeMap<String, String>) -> Result<FileSettings> {
    let known = every_key();
    let mut file = FileSettings {
        source: source.to_string(),
        ..FileSettings::default()
    };
    for (written, value) in solver {
        let norm = written.trim().to_ascii_lowercase().replace('-', "_");
        if let Some((_, new)) = RENAMED.iter().find(|(old, _)| *old == norm) {
            bail!("{source}: [settings.solver] {written}: renamed {new}");
        }
        let key = norm.as_str();
        match key {
            "solver" => file.solver = Some(value.trim().to_string()),
            "preset" => file.preset = Some(value.trim().to_string()),
            _ if known.contains(&key) => file.keys.push(FileKey {
                written: written.clone(),
                key: key.to_string(),
                value: value.clone(),
            }),
            _ => {
                let mut names = known.clone();
                names.extend(["solver", "preset"]);
                let best = names
                    .iter()
                    .map(|n| (edit_distance(&norm, n), *n))
                    .min()
                    .filter(|(d, _)| *d <= 3);
                match best {
                    Some((_, n)) => bail!(
                        "{source}: [settings.solver] {written}: unknown setting (did you mean {n}?)"
                    ),
                    None => bail!(
                        "{source}: [settings.solver] {written}: unknown setting (known: {})",
                        names.join(", ")
                    ),
                }
            }
        }
    }
    if let Some(s) = &file.solver {
        if !SOLVERS.contains(&s.as_str()) {
            bail!(
                "{source}: [settings.solver] solver = {s}: invalid value (solvers: {})",
                SOLVERS.join(", ")
            );
        }
    }
    Ok(file)
}

/// Levenshtein distance, for "did you mean".
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("cube_rez", "cube_res"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("bands", "bands"), 0);
        assert_eq!(edit_distance("per_fram", "per_frame"), 1);
    }

    #[test]
    fn file_keys_are_the_library_keys() {
        let map: BTreeMap<String, String> = [
            ("solver", "dispersive"),
            ("cube-res", "8"),
            ("per-frame", "2"),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
        let f = from_file("s.toml", &map).unwrap();
        assert_eq!(f.solver.as_deref(), Some("dispersive"));
        let keys: Vec<&str> = f.keys.iter().map(|k| k.key.as_str()).collect();
        assert_eq!(keys, ["cube_res", "per_frame"]);
        let bad: BTreeMap<String, String> = [("cube_rez".to_string(), "8".to_string())].into();
        let e = from_file("s.toml", &bad).err().unwrap().to_string();
        assert!(e.contains("did you mean cube_res?"), "{e}");
        let old: BTreeMap<String, String> = [("method".to_string(), "grid".to_string())].into();
        let e = from_file("s.toml", &old).err().unwrap().to_string();
        assert_eq!(e, "s.toml: [settings.solver] method: renamed solver");
    }
}
