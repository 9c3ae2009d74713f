//! The solver options of `render` and `animate`: `--solver`, `--preset`, a repeatable
//! `--set key=value`, and the reference's `--rays-per-patch` and `--direct-samples` (which
//! also set the reference that `--compare` measures against). A per-setting flag of before
//! `--set` (`--cube-res 64`) is an error naming its key. Keys, ranges, defaults and docs all come from
//! the library (`shrad::settings`); nothing here states a default or checks a range.
//! `shrad options [SOLVER]` lists the keys.

use anyhow::{anyhow, bail, Result};
use clap::builder::PossibleValuesParser;
use clap::error::ErrorKind;
use clap::{Arg, ArgMatches, Args, Command, FromArgMatches};
use shrad::reference::ReferenceOptions;
use shrad::settings::SOLVERS;
use shrad::solver::SolverChoice;

use crate::settings::FileSettings;

/// Flags that set one solver key each before `--set` (shrad 0.1): each is now an error
/// naming its key, `(flag, key)`.
const REMOVED: &[(&str, &str)] = &[
    ("cube-res", "cube_res"),
    ("emitter-res", "emitter_res"),
    ("bands", "bands"),
    ("schedule", "schedule"),
    ("per-frame", "per_frame"),
    ("max-staleness", "max_staleness"),
    ("budget-ms", "budget_ms"),
    ("repair", "repair"),
    ("wall-exchange", "wall_exchange"),
    ("see-through-self", "see_through_self"),
    ("direct-interior", "direct_on_interior"),
    ("to-boundary", "to_boundary"),
    ("contact-rays", "contact_rays"),
    ("emitter-per-face", "emitter_per_face"),
    ("self-shadow-rays", "self_shadow_rays"),
    ("splat-smoothing", "splat_smoothing"),
    ("probe-margin", "probe_margin"),
    ("grid", "per_axis"),
];

/// The removed flags, hidden: given, they are an error that names `--set KEY=VALUE`.
#[derive(Clone, Default)]
pub struct RemovedFlags;

impl FromArgMatches for RemovedFlags {
    fn from_arg_matches(m: &ArgMatches) -> Result<Self, clap::Error> {
        for &(flag, key) in REMOVED {
            if let Some(v) = m.get_one::<String>(flag) {
                return Err(clap::Error::raw(
                    ErrorKind::UnknownArgument,
                    format!("--{flag} is no longer a flag: use --set {key}={v}\n"),
                ));
            }
        }
        Ok(RemovedFlags)
    }
    fn update_from_arg_matches(&mut self, m: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

impl Args for RemovedFlags {
    fn augment_args(mut cmd: Command) -> Command {
        for &(flag, _) in REMOVED {
            cmd = cmd.arg(
                Arg::new(flag)
                    .long(flag)
                    .hide(true)
                    .allow_negative_numbers(true),
            );
        }
        cmd
    }
    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

/// Settings of every solver (`Default`: none given, as `shrad info` reads a file's).
#[derive(Args, Clone, Default)]
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
    /// Rays per patch of the reference: the reference solver's (`--set rays_per_patch=N`)
    /// and the reference any error is measured against (render's `--compare`, animate's
    /// `--error-every`, the viewer's error button).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub rays_per_patch: Option<String>,
    /// Direct-light samples of the reference, as `--rays-per-patch`.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub direct_samples: Option<String>,
    #[command(flatten)]
    pub removed: RemovedFlags,
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
    /// The reference's flags (`--rays-per-patch`, `--direct-samples`) as settings.
    fn reference_flags(&self) -> Vec<Pending> {
        [
            ("rays-per-patch", "rays_per_patch", &self.rays_per_patch),
            ("direct-samples", "direct_samples", &self.direct_samples),
        ]
        .into_iter()
        .filter_map(|(flag, key, value)| {
            value.as_ref().map(|value| Pending {
                key: key.to_string(),
                value: value.clone(),
                origin: format!("--{flag} {value}"),
            })
        })
        .collect()
    }

    /// The `--set` pairs, after the reference's flags when the solver is the reference.
    fn command_line(&self, reference_too: bool) -> Result<Vec<Pending>> {
        let mut v = if reference_too {
            self.reference_flags()
        } else {
            Vec::new()
        };
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
    /// skipped (with a note unless `quiet`); on the command line they are errors.
    /// `--rays-per-patch` and `--direct-samples` set the reference solver too.
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
        let pending = self.reference_flags();
        apply(&mut choice, &pending)?;
        let SolverChoice::Reference(r) = choice else {
            bail!("the reference settings became another solver's");
        };
        Ok(r)
    }
}
