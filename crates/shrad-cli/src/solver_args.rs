//! The solver options of `render` and `animate`: `--solver`, `--preset`, a repeatable
//! `--set key=value`, and the older per-setting flags kept as aliases of keys
//! (`--cube-res 64` is `--set cube_res=64`). Keys, ranges, defaults and docs all come from
//! the library (`shrad::settings`); nothing here states a default or checks a range.
//! `shrad options [SOLVER]` lists the keys.

use anyhow::{anyhow, bail, Result};
use clap::builder::PossibleValuesParser;
use clap::{Arg, ArgMatches, Args, Command, FromArgMatches};
use shrad::reference::ReferenceOptions;
use shrad::settings::SOLVERS;
use shrad::solver::SolverChoice;

use crate::settings::FileSettings;

/// Which settings an alias flag sets.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    /// The chosen solver's key.
    Solver,
    /// The reference's key: the reference solver's, and the reference that `--compare` and
    /// `--error-every` measure against.
    Reference,
}

/// An older flag that is now an alias of a key: (flag, key, target).
const ALIASES: &[(&str, &str, Target)] = &[
    ("cube-res", "cube_res", Target::Solver),
    ("emitter-res", "emitter_res", Target::Solver),
    ("bands", "bands", Target::Solver),
    ("schedule", "schedule", Target::Solver),
    ("per-frame", "per_frame", Target::Solver),
    ("max-staleness", "max_staleness", Target::Solver),
    ("budget-ms", "budget_ms", Target::Solver),
    ("repair", "repair", Target::Solver),
    ("wall-exchange", "wall_exchange", Target::Solver),
    ("see-through-self", "see_through_self", Target::Solver),
    ("direct-interior", "direct_on_interior", Target::Solver),
    ("to-boundary", "to_boundary", Target::Solver),
    ("contact-rays", "contact_rays", Target::Solver),
    ("emitter-per-face", "emitter_per_face", Target::Solver),
    ("self-shadow-rays", "self_shadow_rays", Target::Solver),
    ("splat-smoothing", "splat_smoothing", Target::Solver),
    ("probe-margin", "probe_margin", Target::Solver),
    ("grid", "per_axis", Target::Solver),
    ("rays-per-patch", "rays_per_patch", Target::Reference),
    ("direct-samples", "direct_samples", Target::Reference),
];

const ALIAS_HEADING: &str = "Aliases of --set (shrad options lists every key)";

/// A value in the spelling of the flags before the keys (`--repair move`).
fn old_spelling<'a>(key: &str, value: &'a str) -> &'a str {
    match (key, value.trim()) {
        ("repair", "move") => "move_inward",
        _ => value,
    }
}

/// The first solver (dispersive, grid, reference) that has `key`, with the key's doc.
fn doc_of(key: &str) -> (&'static str, &'static str) {
    for solver in SOLVERS {
        if let Ok(keys) = SolverChoice::keys_of(solver) {
            if let Some(spec) = keys.iter().find(|s| s.name == key) {
                return (solver, spec.doc);
            }
        }
    }
    ("", "")
}

/// The alias flags given, in the table's order: (flag, key, target, value).
#[derive(Clone, Default)]
pub struct Aliases(Vec<(&'static str, &'static str, Target, String)>);

impl FromArgMatches for Aliases {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        let mut a = Aliases::default();
        a.update_from_arg_matches(m)?;
        Ok(a)
    }
    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        for &(flag, key, target) in ALIASES {
            if let Some(v) = m.get_one::<String>(flag) {
                self.0.retain(|(f, ..)| *f != flag);
                self.0.push((flag, key, target, v.clone()));
            }
        }
        Ok(())
    }
}

impl Args for Aliases {
    fn augment_args(mut cmd: Command) -> Command {
        for &(flag, key, target) in ALIASES {
            let (solver, doc) = doc_of(key);
            let help = match target {
                Target::Solver => format!("Alias of --set {key}=VALUE ({solver}: {doc})"),
                Target::Reference => format!(
                    "Alias of --set {key}=VALUE for the reference: the reference solver, and the reference --compare and --error-every measure against ({doc})"
                ),
            };
            cmd = cmd.arg(
                Arg::new(flag)
                    .long(flag)
                    .value_name("VALUE")
                    .allow_negative_numbers(true)
                    .help(help)
                    .help_heading(ALIAS_HEADING),
            );
        }
        cmd
    }
    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

/// Settings of every solver.
#[derive(Args, Clone)]
pub struct SolverArgs {
    /// Which solver computes the radiosity [default: the scene file's `solver`, else
    /// reference].
    #[arg(long, value_parser = PossibleValuesParser::new(SOLVERS))]
    pub solver: Option<String>,
    /// The solver's starting settings (`shrad options SOLVER` lists its presets) [default:
    /// the scene file's `preset`, else the solver's default].
    #[arg(long)]
    pub preset: Option<String>,
    /// Set one of the solver's settings (repeatable); `shrad options SOLVER` lists every key
    /// with its default, range and doc.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    #[command(flatten)]
    pub aliases: Aliases,
}

/// One setting to apply and where it came from, for messages.
struct Pending {
    key: String,
    value: String,
    origin: String,
}

fn normalise(key: &str) -> String {
    key.trim().to_ascii_lowercase().replace('-', "_")
}

/// Apply `pending` to `choice`, `schedule` first (its parameters depend on it); an error
/// names where the setting came from.
fn apply(choice: &mut SolverChoice, pending: &[Pending]) -> Result<()> {
    let ordered = pending
        .iter()
        .filter(|p| p.key == "schedule")
        .chain(pending.iter().filter(|p| p.key != "schedule"));
    for p in ordered {
        choice
            .set(&p.key, &p.value)
            .map_err(|e| anyhow!("{}: {e}", p.origin))?;
    }
    Ok(())
}

impl SolverArgs {
    /// The `--set` pairs and the aliases of `target` (the solver's, or also the
    /// reference's when the solver is the reference), as given.
    fn command_line(&self, reference_too: bool) -> Result<Vec<Pending>> {
        let mut v = Vec::new();
        for &(flag, key, target, ref value) in &self.aliases.0 {
            if target == Target::Solver || reference_too {
                v.push(Pending {
                    key: key.to_string(),
                    value: old_spelling(key, value).to_string(),
                    origin: format!("--{flag} {value}"),
                });
            }
        }
        for s in &self.set {
            let (key, value) = s
                .split_once('=')
                .ok_or_else(|| anyhow!("--set {s}: expected KEY=VALUE"))?;
            v.push(Pending {
                key: normalise(key),
                value: value.to_string(),
                origin: format!("--set {s}"),
            });
        }
        Ok(v)
    }

    /// The solver and its settings: the preset, then the scene file's keys the command line
    /// does not set, then the command line's. Keys of another solver in the file are
    /// skipped (with a note unless `quiet`); on the command line they are errors. The
    /// reference aliases set the reference solver too.
    pub fn choice(&self, file: &FileSettings, quiet: bool) -> Result<SolverChoice> {
        let solver = self
            .solver
            .as_deref()
            .or(file.solver.as_deref())
            .unwrap_or("reference");
        let preset = self
            .preset
            .as_deref()
            .or(file.preset.as_deref())
            .unwrap_or("default");
        let origin = if self.preset.is_some() {
            "--preset".to_string()
        } else if file.preset.is_some() {
            format!("{}: [settings.solver] preset", file.source)
        } else {
            "--preset".to_string()
        };
        let mut choice =
            SolverChoice::preset(solver, preset).map_err(|e| anyhow!("{origin}: {e}"))?;
        let cli = self.command_line(matches!(choice, SolverChoice::Reference(_)))?;
        let mut pending = Vec::new();
        for s in &file.keys {
            if cli.iter().any(|p| p.key == s.key) {
                continue; // The command line wins.
            }
            if choice.key(&s.key).is_err() {
                if !quiet {
                    eprintln!(
                        "note: {}: [settings.solver] {} is not a setting of the {} solver: not used",
                        file.source,
                        s.written,
                        choice.name()
                    );
                }
                continue;
            }
            pending.push(Pending {
                key: s.key.clone(),
                value: s.value.clone(),
                origin: format!(
                    "{}: [settings.solver] {} = {}",
                    file.source, s.written, s.value
                ),
            });
        }
        pending.extend(cli);
        apply(&mut choice, &pending)?;
        Ok(choice)
    }

    /// The reference that `--compare` and `--error-every` measure against: the library's
    /// standard one with `--rays-per-patch` and `--direct-samples`.
    pub fn reference(&self) -> Result<ReferenceOptions> {
        self.reference_over(ReferenceOptions::standard())
    }

    /// `base` with `--rays-per-patch` and `--direct-samples` (the viewer's error button
    /// starts from the fast reference, to answer in seconds).
    pub fn reference_over(&self, base: ReferenceOptions) -> Result<ReferenceOptions> {
        let mut choice = SolverChoice::Reference(base);
        let pending: Vec<Pending> = self
            .aliases
            .0
            .iter()
            .filter(|(.., target, _)| *target == Target::Reference)
            .map(|(flag, key, _, value)| Pending {
                key: key.to_string(),
                value: value.clone(),
                origin: format!("--{flag} {value}"),
            })
            .collect();
        apply(&mut choice, &pending)?;
        let SolverChoice::Reference(r) = choice else {
            bail!("the reference settings became another solver's");
        };
        Ok(r)
    }
}
