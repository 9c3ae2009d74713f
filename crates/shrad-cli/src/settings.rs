//! A scene file's `[settings.solver]` applied as command-line options: each key is a solver
//! option's long name (`cube-res` or `cube_res`), its value what the option takes; an option
//! given on the command line wins over the file. Unknown keys and bad values are errors
//! naming the file and the key.

use std::collections::BTreeMap;
use std::ffi::OsString;

use anyhow::{anyhow, bail, Result};
use clap::parser::ValueSource;
use clap::{ArgMatches, Args, Parser};

/// Names the scene files used before the keys were the options' own.
const ALIASES: [(&str, &str); 2] = [("objects-per-frame", "per-frame"), ("method", "solver")];

/// One setting of the file that is applied (its option was not on the command line).
pub struct FileSetting {
    /// The key as written in the file.
    pub key: String,
    /// The option's long name.
    pub long: String,
    /// The value as written.
    pub value: String,
}

/// The applied settings of one scene file.
#[derive(Default)]
pub struct FileSettings {
    /// The scene file, for messages.
    pub source: String,
    /// Settings not overridden by the command line.
    pub applied: Vec<FileSetting>,
}

impl FileSettings {
    /// `error` named after the file and key when it is about an option the file set.
    pub fn attribute(&self, error: anyhow::Error) -> anyhow::Error {
        let msg = format!("{error:#}");
        match self
            .applied
            .iter()
            .find(|s| msg.contains(&format!("--{} ", s.long)))
        {
            Some(s) => anyhow!(
                "{}: [settings.solver] {} = {}: {msg}",
                self.source,
                s.key,
                s.value
            ),
            None => error,
        }
    }
}

/// The solver options a scene file may set: (argument id, long name).
fn solver_options() -> Vec<(String, String)> {
    crate::SolverArgs::augment_args(clap::Command::new("settings"))
        .get_arguments()
        .filter_map(|a| Some((a.get_id().to_string(), a.get_long()?.to_string())))
        .collect()
}

/// Check every key of `solver` (from the scene file `source`) and keep those whose option
/// `matches` (the subcommand's, when it has the solver options) did not get from the command
/// line.
pub fn from_file(
    source: &str,
    solver: &BTreeMap<String, String>,
    matches: Option<&ArgMatches>,
) -> Result<FileSettings> {
    let options = solver_options();
    let mut applied = Vec::new();
    for (key, value) in solver {
        let norm = key.trim().to_ascii_lowercase().replace('_', "-");
        let long = ALIASES
            .iter()
            .find(|(a, _)| *a == norm)
            .map_or(norm.as_str(), |(_, l)| l);
        let Some((id, long)) = options.iter().find(|(_, l)| l == long) else {
            let best = options
                .iter()
                .map(|(_, l)| (edit_distance(&norm, l), l))
                .min()
                .filter(|(d, _)| *d <= 3);
            match best {
                Some((_, l)) => {
                    bail!("{source}: [settings.solver] {key}: unknown setting (did you mean {l}?)")
                }
                None => {
                    let all: Vec<&str> = options.iter().map(|(_, l)| l.as_str()).collect();
                    bail!(
                        "{source}: [settings.solver] {key}: unknown setting (known: {})",
                        all.join(", ")
                    )
                }
            }
        };
        if let Some(m) = matches {
            if m.value_source(id) == Some(ValueSource::CommandLine) {
                continue;
            }
        }
        applied.push(FileSetting {
            key: key.clone(),
            long: long.clone(),
            value: value.clone(),
        });
    }
    Ok(FileSettings {
        source: source.to_string(),
        applied,
    })
}

/// Parse the command line again with the file's settings placed before the user's
/// arguments (`argv[1]` is the subcommand). Each setting is tried alone first, so a bad
/// value is reported with its key.
pub fn reparse(argv: &[OsString], settings: &FileSettings) -> Result<crate::Cli> {
    let with = |extra: &[OsString]| -> Vec<OsString> {
        let mut v: Vec<OsString> = argv.iter().take(2).cloned().collect();
        v.extend_from_slice(extra);
        v.extend(argv.iter().skip(2).cloned());
        v
    };
    let mut extra = Vec::with_capacity(settings.applied.len());
    for s in &settings.applied {
        let arg = OsString::from(format!("--{}={}", s.long, s.value));
        if let Err(e) = crate::Cli::try_parse_from(with(std::slice::from_ref(&arg))) {
            bail!(
                "{}: [settings.solver] {} = {}: {}",
                settings.source,
                s.key,
                s.value,
                clap_message(&e)
            );
        }
        extra.push(arg);
    }
    crate::Cli::try_parse_from(with(&extra)).map_err(|e| {
        anyhow!(
            "{}: [settings.solver]: {}",
            settings.source,
            clap_message(&e)
        )
    })
}

/// The first line of a clap error, without its `error: ` prefix.
fn clap_message(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let line = text.lines().next().unwrap_or_default();
    line.strip_prefix("error: ").unwrap_or(line).to_string()
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
    use super::edit_distance;

    #[test]
    fn edit_distance_counts_edits() {
        assert_eq!(edit_distance("cube-rez", "cube-res"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("bands", "bands"), 0);
        assert_eq!(edit_distance("per-fram", "per-frame"), 1);
    }
}
