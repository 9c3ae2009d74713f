//! Every solver setting by name: one table of [`KeySpec`]s per solver holds each key's doc,
//! range and whether changing it needs the precomputation again; the defaults are the
//! presets' own (the `const fn` constructors [`DispersiveOptions::paper`] /
//! [`improved`](DispersiveOptions::improved), [`GridOptions::paper`],
//! [`ReferenceOptions::standard`] / [`fast`](ReferenceOptions::fast)). The CLI's `--set`,
//! a scene file's `[settings.solver]` and Python all go through here, so a value out of range
//! is an [`Error::Invalid`] naming the key and its range, never a panic further down.
//!
//! ```
//! use shrad::solver::SolverChoice;
//! let mut choice = SolverChoice::preset("dispersive", "paper")?;
//! choice.set("cube_res", "64")?;
//! choice.set("schedule", "priority")?; // the Schedule enum is flattened into keys
//! choice.set("max_staleness", "8")?;
//! assert_eq!(choice.get("cube_res")?, "64");
//! assert!(choice.set("bands", "9").is_err()); // "dispersive bands = 9: ... 1..=8"
//! for key in SolverChoice::keys_of("grid")? {
//!     println!("{} ({}): {}", key.name, key.range, key.doc);
//! }
//! // With the default of every preset, for `shrad options`:
//! let table = shrad::settings::describe("dispersive")?;
//! assert_eq!(table[0].defaults[0].0, "default");
//! # Ok::<(), shrad::Error>(())
//! ```
//!
//! An [`Engine`](crate::engine::Engine) changes one key live with `set_option`: scheduler
//! keys apply at once, the others rebuild the solver's precomputation and say so.

use std::fmt;

use crate::dispersive::{DispersiveOptions, ProbeRepair, Schedule, ToBoundary};
use crate::grid::GridOptions;
use crate::reference::ReferenceOptions;
use crate::solver::SolverChoice;
use crate::Error;

/// The solvers, by name.
pub const SOLVERS: [&str; 3] = ["dispersive", "grid", "reference"];

/// The values a key takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Range {
    /// An integer in `min..=max`.
    Int {
        /// Smallest value.
        min: u64,
        /// Largest value.
        max: u64,
    },
    /// A finite number in `min..=max` (`min` itself excluded when `min_open`).
    Float {
        /// Lower end.
        min: f64,
        /// Upper end (included).
        max: f64,
        /// `min` is not allowed.
        min_open: bool,
    },
    /// `true` or `false`.
    Bool,
    /// One of these names.
    Choice(&'static [&'static str]),
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Range::Int { min, max } => write!(f, "integer {min}..={max}"),
            Range::Float {
                min,
                max,
                min_open: false,
            } => write!(f, "number {min}..={max}"),
            Range::Float {
                min,
                max,
                min_open: true,
            } => write!(f, "number > {min} and <= {max}"),
            Range::Bool => write!(f, "true|false"),
            Range::Choice(names) => write!(f, "{}", names.join("|")),
        }
    }
}

/// One setting of a solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeySpec {
    /// The key (`snake_case`; `-` is accepted for `_`).
    pub name: &'static str,
    /// What it does.
    pub doc: &'static str,
    /// The values it takes (`Display` gives the text `shrad options` prints).
    pub range: Range,
    /// Changing it runs the solver's precomputation again (probe boxes, transfer, form
    /// factors...); scheduler keys do not.
    pub rebuilds: bool,
}

/// A key of a solver with its default in each preset, for listings (`shrad options`).
#[derive(Clone, Debug, PartialEq)]
pub struct KeyInfo {
    /// The key.
    pub name: &'static str,
    /// What it does.
    pub doc: &'static str,
    /// The values it takes, as text.
    pub range: String,
    /// Whether changing it needs the precomputation again.
    pub rebuilds: bool,
    /// `(preset, default)` for every preset of the solver, the solver's default first; `-`
    /// where the preset's schedule does not use the key.
    pub defaults: Vec<(&'static str, String)>,
}

/// A setting's value, parsed and checked against its [`Range`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum Value {
    Int(u64),
    Float(f64),
    Bool(bool),
    Choice(&'static str),
    /// The key does not apply in this state (a schedule parameter of another schedule).
    Unused,
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Int(v) => write!(f, "{v}"),
            // The settings are f32: print them as such (0.01, not 0.009999999776482582).
            Value::Float(v) => write!(f, "{}", *v as f32),
            Value::Bool(v) => write!(f, "{v}"),
            Value::Choice(v) => write!(f, "{v}"),
            Value::Unused => write!(f, "-"),
        }
    }
}

const fn int(name: &'static str, min: u64, max: u64, rebuilds: bool, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Int { min, max },
        rebuilds,
    }
}

const fn float(name: &'static str, min: f64, max: f64, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Float {
            min,
            max,
            min_open: false,
        },
        rebuilds: true,
    }
}

const fn flag(name: &'static str, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Bool,
        rebuilds: true,
    }
}

const fn choice(
    name: &'static str,
    names: &'static [&'static str],
    rebuilds: bool,
    doc: &'static str,
) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Choice(names),
        rebuilds,
    }
}

/// Largest cube-map face resolution (2048^2 x 6 texels a probe).
const MAX_RES: u64 = 2048;
/// Most SH bands `shrad-sh` evaluates.
const MAX_BANDS: u64 = 8;
/// Most rays per patch of any per-patch ray count.
const MAX_RAYS: u64 = 65_536;

/// The schedules, as the `schedule` key names them.
const SCHEDULES: &[&str] = &["round_robin", "priority", "budget", "full"];
/// The probe repairs, as the `repair` key names them.
const REPAIRS: &[&str] = &["none", "drop", "move_inward"];
/// The Step 3 methods, as the `to_boundary` key names them.
const TO_BOUNDARY: &[&str] = &["splat", "gather", "auto"];

/// A schedule parameter missing from the schedule switched from takes this.
const DEFAULT_PER_FRAME: usize = 1;
/// See [`DEFAULT_PER_FRAME`].
const DEFAULT_MAX_STALENESS: usize = 16;
/// See [`DEFAULT_PER_FRAME`].
const DEFAULT_BUDGET_MS: f32 = 20.0;

/// The dispersive solver's keys (fields of [`DispersiveOptions`]; `schedule`, `per_frame`,
/// `max_staleness` and `budget_ms` flatten its [`Schedule`]).
pub const DISPERSIVE_KEYS: &[KeySpec] = &[
    int("bands", 1, MAX_BANDS, true, "SH bands (paper: 4 = 16 coefficients)"),
    int(
        "cube_res",
        1,
        MAX_RES,
        true,
        "cube-map face resolution of the probes (paper: 128; 32 measures as well once direct light on interior objects is computed apart)",
    ),
    int(
        "emitter_res",
        1,
        MAX_RES,
        true,
        "cube-map face resolution of the Step 3 splat from each object (paper: the probes' 128)",
    ),
    float(
        "probe_margin",
        0.0,
        1.0,
        "probe box margin as a fraction of the box diagonal (paper: 0, the exact box)",
    ),
    choice(
        "schedule",
        SCHEDULES,
        false,
        "which objects a frame updates: in order, by priority (motion, staleness), as many as fit in budget_ms, or all",
    ),
    int(
        "per_frame",
        1,
        1_000_000,
        false,
        "objects updated per frame, K (schedule round_robin and priority)",
    ),
    int(
        "max_staleness",
        1,
        1_000_000,
        false,
        "no object waits more frames than this (schedule priority and budget)",
    ),
    KeySpec {
        name: "budget_ms",
        doc: "per-frame time budget for Steps 2 and 3, at least one object a frame (schedule budget)",
        range: Range::Float {
            min: 0.0,
            max: 60_000.0,
            min_open: true,
        },
        rebuilds: false,
    },
    float(
        "invalid_back_fraction",
        0.0,
        1.0,
        "back-face fraction above which a probe is invalid (DDGI: 0.25)",
    ),
    choice(
        "repair",
        REPAIRS,
        true,
        "invalid probes: kept (the paper), dropped with the weights renormalised, or moved towards the box centre",
    ),
    flag(
        "wall_exchange",
        "carry boundary-to-boundary light (precomputed sparse form factors, one Jacobi sweep a frame)",
    ),
    int(
        "wall_rays",
        1,
        MAX_RAYS,
        true,
        "form-factor rays per boundary patch for the wall exchange",
    ),
    flag(
        "see_through_self",
        "capture probes with the object's own geometry transparent (else its texels are black)",
    ),
    flag(
        "direct_on_interior",
        "direct light on interior patches computed like the boundary's; probes then carry reflected light only",
    ),
    int(
        "direct_samples",
        1,
        MAX_RAYS,
        true,
        "shadow rays per (patch, emitter) for direct light",
    ),
    choice(
        "to_boundary",
        TO_BOUNDARY,
        true,
        "Step 3: the paper's cube-map splat, a per-patch gather with a shadow ray, or gather on small boundaries and splat on large ones",
    ),
    int(
        "contact_rays",
        0,
        4096,
        true,
        "rays per interior patch detecting faces in contact with other surfaces (0: off, the paper)",
    ),
    flag(
        "emitter_per_face",
        "Step 3 with one SH emitter per face direction of the object instead of one at its centre",
    ),
    int(
        "self_shadow_rays",
        0,
        MAX_RAYS,
        true,
        "rays per interior patch for transfer vectors with self-visibility, so concave objects shadow and light themselves (0: the plain cosine lobe)",
    ),
    flag(
        "splat_smoothing",
        "spread each boundary patch's splatted flux over its edge neighbours, against the texel pattern",
    ),
];

/// The grid baseline's keys (fields of [`GridOptions`]).
pub const GRID_KEYS: &[KeySpec] = &[
    int(
        "per_axis",
        1,
        64,
        true,
        "probes per axis, G (paper: 4 and 5)",
    ),
    int(
        "cube_res",
        1,
        MAX_RES,
        true,
        "cube-map face resolution of the probes (paper: 128)",
    ),
    int("bands", 1, MAX_BANDS, true, "SH bands (paper: 4)"),
];

/// The reference solver's keys (fields of [`ReferenceOptions`]). It keeps nothing between
/// frames, so none needs a rebuild.
pub const REFERENCE_KEYS: &[KeySpec] = &[
    int(
        "rays_per_patch",
        1,
        MAX_RAYS,
        false,
        "form-factor rays per patch (256: about 3 % noise per patch on the indirect term)",
    ),
    int(
        "direct_samples",
        1,
        MAX_RAYS,
        false,
        "shadow rays per (patch, emitter) for the visible fraction of direct light",
    ),
    KeySpec {
        name: "tolerance",
        doc: "stop iterating when max |dB| <= tolerance * max B",
        range: Range::Float {
            min: 0.0,
            max: 1.0,
            min_open: true,
        },
        rebuilds: false,
    },
    int(
        "max_iterations",
        1,
        1_000_000,
        false,
        "give up after this many Jacobi iterations (reported as not converged)",
    ),
];

/// The keys of one solver's typed settings, read and written as [`Value`]s.
trait Keyed {
    fn read(&self, key: &str) -> Value;
    /// `value` is already checked against the key's range.
    fn write(&mut self, key: &str, value: Value) -> Result<(), String>;
}

fn as_int(v: Value) -> u64 {
    match v {
        Value::Int(v) => v,
        _ => unreachable!("value checked against an integer range"),
    }
}

fn as_usize(v: Value) -> usize {
    usize::try_from(as_int(v)).unwrap_or(usize::MAX)
}

fn as_u32(v: Value) -> u32 {
    u32::try_from(as_int(v)).unwrap_or(u32::MAX)
}

fn as_f32(v: Value) -> f32 {
    match v {
        Value::Float(v) => v as f32,
        _ => unreachable!("value checked against a number range"),
    }
}

fn as_bool(v: Value) -> bool {
    match v {
        Value::Bool(v) => v,
        _ => unreachable!("value checked as true|false"),
    }
}

fn as_choice(v: Value) -> &'static str {
    match v {
        Value::Choice(v) => v,
        _ => unreachable!("value checked against a list of names"),
    }
}

impl Keyed for DispersiveOptions {
    fn read(&self, key: &str) -> Value {
        let (per_frame, max_staleness, budget_ms) = match self.schedule {
            Schedule::RoundRobin { per_frame } => (Some(per_frame), None, None),
            Schedule::Priority {
                per_frame,
                max_staleness,
            } => (Some(per_frame), Some(max_staleness), None),
            Schedule::Budget { ms, max_staleness } => (None, Some(max_staleness), Some(ms)),
            Schedule::Full => (None, None, None),
        };
        let size = |v: usize| Value::Int(v as u64);
        match key {
            "bands" => size(self.bands),
            "cube_res" => size(self.cube_res),
            "emitter_res" => size(self.emitter_res),
            "probe_margin" => Value::Float(self.probe_margin.into()),
            "schedule" => Value::Choice(match self.schedule {
                Schedule::RoundRobin { .. } => "round_robin",
                Schedule::Priority { .. } => "priority",
                Schedule::Budget { .. } => "budget",
                Schedule::Full => "full",
            }),
            "per_frame" => per_frame.map_or(Value::Unused, size),
            "max_staleness" => max_staleness.map_or(Value::Unused, size),
            "budget_ms" => budget_ms.map_or(Value::Unused, |ms| Value::Float(ms.into())),
            "invalid_back_fraction" => Value::Float(self.invalid_back_fraction.into()),
            "repair" => Value::Choice(match self.repair {
                ProbeRepair::None => "none",
                ProbeRepair::Drop => "drop",
                ProbeRepair::MoveInward => "move_inward",
            }),
            "wall_exchange" => Value::Bool(self.wall_exchange),
            "wall_rays" => Value::Int(self.wall_rays.into()),
            "see_through_self" => Value::Bool(self.see_through_self),
            "direct_on_interior" => Value::Bool(self.direct_on_interior),
            "direct_samples" => Value::Int(self.direct_samples.into()),
            "to_boundary" => Value::Choice(match self.to_boundary {
                ToBoundary::Splat => "splat",
                ToBoundary::Gather => "gather",
                ToBoundary::Auto => "auto",
            }),
            "contact_rays" => Value::Int(self.contact_rays.into()),
            "emitter_per_face" => Value::Bool(self.emitter_per_face),
            "self_shadow_rays" => Value::Int(self.self_shadow_rays.into()),
            "splat_smoothing" => Value::Bool(self.splat_smoothing),
            _ => unreachable!("key {key} is in DISPERSIVE_KEYS"),
        }
    }

    fn write(&mut self, key: &str, value: Value) -> Result<(), String> {
        let schedule_name = as_choice(self.read("schedule"));
        let unused = || {
            let users = match key {
                "per_frame" => "round_robin and priority",
                "max_staleness" => "priority and budget",
                _ => "budget",
            };
            format!("{key} is used only by schedule {users}, and the schedule is {schedule_name}; set schedule first")
        };
        match key {
            "bands" => self.bands = as_usize(value),
            "cube_res" => self.cube_res = as_usize(value),
            "emitter_res" => self.emitter_res = as_usize(value),
            "probe_margin" => self.probe_margin = as_f32(value),
            "schedule" => {
                // Parameters the new schedule shares with the old one carry over.
                let old = |k: &str, default: Value| match self.read(k) {
                    Value::Unused => default,
                    v => v,
                };
                let per_frame = as_usize(old("per_frame", Value::Int(DEFAULT_PER_FRAME as u64)));
                let max_staleness = as_usize(old(
                    "max_staleness",
                    Value::Int(DEFAULT_MAX_STALENESS as u64),
                ));
                let ms = as_f32(old("budget_ms", Value::Float(DEFAULT_BUDGET_MS.into())));
                self.schedule = match as_choice(value) {
                    "round_robin" => Schedule::RoundRobin { per_frame },
                    "priority" => Schedule::Priority {
                        per_frame,
                        max_staleness,
                    },
                    "budget" => Schedule::Budget { ms, max_staleness },
                    _ => Schedule::Full,
                };
            }
            "per_frame" => match &mut self.schedule {
                Schedule::RoundRobin { per_frame } | Schedule::Priority { per_frame, .. } => {
                    *per_frame = as_usize(value)
                }
                _ => return Err(unused()),
            },
            "max_staleness" => match &mut self.schedule {
                Schedule::Priority { max_staleness, .. }
                | Schedule::Budget { max_staleness, .. } => *max_staleness = as_usize(value),
                _ => return Err(unused()),
            },
            "budget_ms" => match &mut self.schedule {
                Schedule::Budget { ms, .. } => *ms = as_f32(value),
                _ => return Err(unused()),
            },
            "invalid_back_fraction" => self.invalid_back_fraction = as_f32(value),
            "repair" => {
                self.repair = match as_choice(value) {
                    "none" => ProbeRepair::None,
                    "drop" => ProbeRepair::Drop,
                    _ => ProbeRepair::MoveInward,
                }
            }
            "wall_exchange" => self.wall_exchange = as_bool(value),
            "wall_rays" => self.wall_rays = as_u32(value),
            "see_through_self" => self.see_through_self = as_bool(value),
            "direct_on_interior" => self.direct_on_interior = as_bool(value),
            "direct_samples" => self.direct_samples = as_u32(value),
            "to_boundary" => {
                self.to_boundary = match as_choice(value) {
                    "splat" => ToBoundary::Splat,
                    "gather" => ToBoundary::Gather,
                    _ => ToBoundary::Auto,
                }
            }
            "contact_rays" => self.contact_rays = as_u32(value),
            "emitter_per_face" => self.emitter_per_face = as_bool(value),
            "self_shadow_rays" => self.self_shadow_rays = as_u32(value),
            "splat_smoothing" => self.splat_smoothing = as_bool(value),
            _ => unreachable!("key {key} is in DISPERSIVE_KEYS"),
        }
        Ok(())
    }
}

impl Keyed for GridOptions {
    fn read(&self, key: &str) -> Value {
        Value::Int(match key {
            "per_axis" => self.per_axis,
            "cube_res" => self.cube_res,
            "bands" => self.bands,
            _ => unreachable!("key {key} is in GRID_KEYS"),
        } as u64)
    }

    fn write(&mut self, key: &str, value: Value) -> Result<(), String> {
        let v = as_usize(value);
        match key {
            "per_axis" => self.per_axis = v,
            "cube_res" => self.cube_res = v,
            "bands" => self.bands = v,
            _ => unreachable!("key {key} is in GRID_KEYS"),
        }
        Ok(())
    }
}

impl Keyed for ReferenceOptions {
    fn read(&self, key: &str) -> Value {
        match key {
            "rays_per_patch" => Value::Int(self.rays_per_patch.into()),
            "direct_samples" => Value::Int(self.direct_samples.into()),
            "tolerance" => Value::Float(self.tolerance.into()),
            "max_iterations" => Value::Int(self.max_iterations as u64),
            _ => unreachable!("key {key} is in REFERENCE_KEYS"),
        }
    }

    fn write(&mut self, key: &str, value: Value) -> Result<(), String> {
        match key {
            "rays_per_patch" => self.rays_per_patch = as_u32(value),
            "direct_samples" => self.direct_samples = as_u32(value),
            "tolerance" => self.tolerance = as_f32(value),
            "max_iterations" => self.max_iterations = as_usize(value),
            _ => unreachable!("key {key} is in REFERENCE_KEYS"),
        }
        Ok(())
    }
}

/// A key as written by a user: trimmed, lower case, `-` for `_`.
fn normalise(s: &str) -> String {
    s.trim().to_ascii_lowercase().replace('-', "_")
}

/// `value` parsed for `spec`, or why not.
fn parse(spec: &KeySpec, value: &str) -> Result<Value, String> {
    let text = value.trim();
    let out_of_range = || format!("must be {}", spec.range);
    match spec.range {
        Range::Int { .. } => {
            let v: u64 = text.parse().map_err(|_| out_of_range())?;
            check(spec, Value::Int(v)).map(|_| Value::Int(v))
        }
        Range::Float { .. } => {
            let v: f64 = text.parse().map_err(|_| out_of_range())?;
            check(spec, Value::Float(v)).map(|_| Value::Float(v))
        }
        Range::Bool => match normalise(text).as_str() {
            "true" => Ok(Value::Bool(true)),
            "false" => Ok(Value::Bool(false)),
            _ => Err(out_of_range()),
        },
        Range::Choice(names) => {
            let n = normalise(text);
            names
                .iter()
                .find(|&&c| c == n)
                .map(|&c| Value::Choice(c))
                .ok_or_else(out_of_range)
        }
    }
}

/// Whether `value` lies in `spec`'s range.
fn check(spec: &KeySpec, value: Value) -> Result<(), String> {
    let ok = match (spec.range, value) {
        (_, Value::Unused) => true,
        (Range::Int { min, max }, Value::Int(v)) => (min..=max).contains(&v),
        (Range::Float { min, max, min_open }, Value::Float(v)) => {
            v.is_finite() && v <= max && (v > min || (!min_open && v == min))
        }
        (Range::Bool, Value::Bool(_)) => true,
        (Range::Choice(names), Value::Choice(c)) => names.contains(&c),
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(format!("must be {}", spec.range))
    }
}

/// The spec of `key` among `keys` of `solver`, or an error listing them.
fn spec_of(solver: &str, keys: &'static [KeySpec], key: &str) -> Result<&'static KeySpec, Error> {
    let k = normalise(key);
    keys.iter().find(|s| s.name == k).ok_or_else(|| {
        let names: Vec<&str> = keys.iter().map(|s| s.name).collect();
        Error::Invalid(format!(
            "the {solver} solver has no option '{key}' (options: {})",
            names.join(", ")
        ))
    })
}

fn get_key<T: Keyed>(
    solver: &str,
    keys: &'static [KeySpec],
    o: &T,
    key: &str,
) -> Result<String, Error> {
    Ok(o.read(spec_of(solver, keys, key)?.name).to_string())
}

fn set_key<T: Keyed>(
    solver: &str,
    keys: &'static [KeySpec],
    o: &mut T,
    key: &str,
    value: &str,
) -> Result<&'static KeySpec, Error> {
    let spec = spec_of(solver, keys, key)?;
    parse(spec, value)
        .and_then(|v| o.write(spec.name, v))
        .map_err(|why| {
            Error::Invalid(format!(
                "{solver} option {} = {}: {why}",
                spec.name,
                value.trim()
            ))
        })?;
    Ok(spec)
}

fn validate_keys<T: Keyed>(solver: &str, keys: &'static [KeySpec], o: &T) -> Result<(), Error> {
    for spec in keys {
        let v = o.read(spec.name);
        check(spec, v)
            .map_err(|why| Error::Invalid(format!("{solver} option {} = {v}: {why}", spec.name)))?;
    }
    Ok(())
}

/// The presets of `solver`, its default first; an error lists the solvers.
pub fn presets(solver: &str) -> Result<&'static [&'static str], Error> {
    Ok(match normalise(solver).as_str() {
        "dispersive" => &["default", "paper"],
        "grid" => &["paper5", "paper4"],
        "reference" => &["standard", "fast"],
        _ => return Err(unknown_solver(solver)),
    })
}

fn unknown_solver(solver: &str) -> Error {
    Error::Invalid(format!(
        "no solver '{solver}' (solvers: {})",
        SOLVERS.join(", ")
    ))
}

/// Every key of `solver` with its doc, range and default in each preset (`shrad options`).
pub fn describe(solver: &str) -> Result<Vec<KeyInfo>, Error> {
    let presets: Vec<(&'static str, SolverChoice)> = presets(solver)?
        .iter()
        .map(|&p| Ok((p, SolverChoice::preset(solver, p)?)))
        .collect::<Result<_, Error>>()?;
    Ok(SolverChoice::keys_of(solver)?
        .iter()
        .map(|spec| KeyInfo {
            name: spec.name,
            doc: spec.doc,
            range: spec.range.to_string(),
            rebuilds: spec.rebuilds,
            defaults: presets
                .iter()
                .map(|(p, c)| (*p, c.get(spec.name).unwrap_or_default()))
                .collect(),
        })
        .collect())
}

impl SolverChoice {
    /// The solver `solver` ([`SOLVERS`]) at preset `preset` ([`presets`]; `default` names
    /// each solver's default preset, `improved` the dispersive default). Errors list the
    /// valid names.
    pub fn preset(solver: &str, preset: &str) -> Result<SolverChoice, Error> {
        let solver_name = normalise(solver);
        let p = normalise(preset);
        let choice = match (solver_name.as_str(), p.as_str()) {
            ("dispersive", "default" | "improved") => {
                SolverChoice::Dispersive(DispersiveOptions::improved())
            }
            ("dispersive", "paper") => SolverChoice::Dispersive(DispersiveOptions::paper()),
            ("grid", "default" | "paper5") => SolverChoice::Grid(GridOptions::paper(5)),
            ("grid", "paper4") => SolverChoice::Grid(GridOptions::paper(4)),
            ("reference", "default" | "standard") => {
                SolverChoice::Reference(ReferenceOptions::standard())
            }
            ("reference", "fast") => SolverChoice::Reference(ReferenceOptions::fast()),
            _ => {
                let valid = presets(solver)?;
                return Err(Error::Invalid(format!(
                    "the {solver_name} solver has no preset '{preset}' (presets: {})",
                    valid.join(", ")
                )));
            }
        };
        Ok(choice)
    }

    /// The solver's name: `dispersive`, `grid` or `reference`.
    pub fn name(&self) -> &'static str {
        match self {
            SolverChoice::Dispersive(_) => "dispersive",
            SolverChoice::Grid(_) => "grid",
            SolverChoice::Reference(_) => "reference",
        }
    }

    /// This solver's keys.
    pub fn keys(&self) -> &'static [KeySpec] {
        match self {
            SolverChoice::Dispersive(_) => DISPERSIVE_KEYS,
            SolverChoice::Grid(_) => GRID_KEYS,
            SolverChoice::Reference(_) => REFERENCE_KEYS,
        }
    }

    /// The keys of the solver called `solver`; an error lists the solvers.
    pub fn keys_of(solver: &str) -> Result<&'static [KeySpec], Error> {
        Ok(match normalise(solver).as_str() {
            "dispersive" => DISPERSIVE_KEYS,
            "grid" => GRID_KEYS,
            "reference" => REFERENCE_KEYS,
            _ => return Err(unknown_solver(solver)),
        })
    }

    /// The spec of `key`; an error lists this solver's keys.
    pub fn key(&self, key: &str) -> Result<&'static KeySpec, Error> {
        spec_of(self.name(), self.keys(), key)
    }

    /// The value of `key` as text (`-` for a schedule parameter the schedule does not use).
    pub fn get(&self, key: &str) -> Result<String, Error> {
        let (name, keys) = (self.name(), self.keys());
        match self {
            SolverChoice::Dispersive(o) => get_key(name, keys, o, key),
            SolverChoice::Grid(o) => get_key(name, keys, o, key),
            SolverChoice::Reference(o) => get_key(name, keys, o, key),
        }
    }

    /// Set `key` from text (numbers, `true|false`, snake_case names); a value out of range is
    /// an error naming the key and its range, and leaves the settings as they were. A
    /// schedule parameter of another schedule than the one in force is an error too (set
    /// `schedule` first, or use [`SolverChoice::set_all`]). Returns the key's spec.
    pub fn set(&mut self, key: &str, value: &str) -> Result<&'static KeySpec, Error> {
        let (name, keys) = (self.name(), self.keys());
        let mut next = *self;
        let spec = match &mut next {
            SolverChoice::Dispersive(o) => set_key(name, keys, o, key, value)?,
            SolverChoice::Grid(o) => set_key(name, keys, o, key, value)?,
            SolverChoice::Reference(o) => set_key(name, keys, o, key, value)?,
        };
        *self = next;
        Ok(spec)
    }

    /// Set several keys, `schedule` before the others whatever their order (so
    /// `budget_ms=10, schedule=budget` works); all or nothing.
    pub fn set_all<K: AsRef<str>, V: AsRef<str>>(&mut self, pairs: &[(K, V)]) -> Result<(), Error> {
        let mut next = *self;
        let is_schedule = |k: &str| normalise(k) == "schedule";
        let ordered = pairs
            .iter()
            .filter(|(k, _)| is_schedule(k.as_ref()))
            .chain(pairs.iter().filter(|(k, _)| !is_schedule(k.as_ref())));
        for (k, v) in ordered {
            next.set(k.as_ref(), v.as_ref())?;
        }
        *self = next;
        Ok(())
    }

    /// Check every key against its range: what [`Engine`](crate::engine::Engine) and
    /// [`Solver::new`](crate::solver::Solver::new) do before precomputing, so options built
    /// as struct literals cannot reach a panic either.
    pub fn validate(&self) -> Result<(), Error> {
        let (name, keys) = (self.name(), self.keys());
        match self {
            SolverChoice::Dispersive(o) => validate_keys(name, keys, o),
            SolverChoice::Grid(o) => validate_keys(name, keys, o),
            SolverChoice::Reference(o) => validate_keys(name, keys, o),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn every_preset() -> Vec<SolverChoice> {
        SOLVERS
            .iter()
            .flat_map(|s| {
                presets(s)
                    .unwrap()
                    .iter()
                    .map(|p| SolverChoice::preset(s, p).unwrap())
            })
            .collect()
    }

    #[test]
    fn every_preset_is_valid_and_every_key_round_trips() {
        for choice in every_preset() {
            choice.validate().unwrap();
            for spec in choice.keys() {
                let text = choice.get(spec.name).unwrap();
                if text == "-" {
                    continue;
                }
                let mut again = choice;
                again.set(spec.name, &text).unwrap();
                assert_eq!(again, choice, "{} {}", choice.name(), spec.name);
            }
        }
    }

    #[test]
    fn presets_are_the_constructors() {
        assert_eq!(
            SolverChoice::preset("dispersive", "paper").unwrap(),
            SolverChoice::Dispersive(DispersiveOptions::paper())
        );
        assert_eq!(
            SolverChoice::preset("dispersive", "default").unwrap(),
            SolverChoice::Dispersive(DispersiveOptions::default())
        );
        assert_eq!(
            SolverChoice::preset("grid", "paper4").unwrap(),
            SolverChoice::Grid(GridOptions::paper(4))
        );
        assert_eq!(
            SolverChoice::preset("reference", "fast").unwrap(),
            SolverChoice::Reference(ReferenceOptions::fast())
        );
        let e = SolverChoice::preset("dispersive", "fastest").unwrap_err();
        assert!(e.to_string().contains("default, paper"), "{e}");
        let e = SolverChoice::preset("path_tracer", "default").unwrap_err();
        assert!(e.to_string().contains("dispersive, grid, reference"), "{e}");
    }

    #[test]
    fn out_of_range_values_are_errors_naming_key_and_range() {
        let mut c = SolverChoice::preset("dispersive", "default").unwrap();
        let before = c;
        for (key, value, says) in [
            ("bands", "9", "1..=8"),
            ("bands", "four", "1..=8"),
            ("cube_res", "0", "1..=2048"),
            ("probe_margin", "NaN", "0..=1"),
            ("probe_margin", "-0.5", "0..=1"),
            ("repair", "move", "none|drop|move_inward"),
            ("wall_exchange", "yes", "true|false"),
            ("budget_ms", "10", "schedule budget"),
        ] {
            let e = c.set(key, value).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains(says), "{key} = {value}: {e}");
            assert_eq!(c, before, "a refused value changes nothing");
        }
        let e = c.set("cube_resolution", "64").unwrap_err().to_string();
        assert!(e.contains("cube_res, emitter_res"), "{e}");
        let mut g = SolverChoice::preset("grid", "default").unwrap();
        assert!(g.set("per_axis", "65").is_err());
        let mut r = SolverChoice::preset("reference", "fast").unwrap();
        assert!(r
            .set("tolerance", "0")
            .unwrap_err()
            .to_string()
            .contains("> 0"));
        // A struct literal out of range is caught by validate.
        let bad = SolverChoice::Dispersive(DispersiveOptions {
            bands: 9,
            ..Default::default()
        });
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("bands = 9"));
    }

    #[test]
    fn the_schedule_is_flattened_into_keys() {
        let mut c = SolverChoice::preset("dispersive", "paper").unwrap();
        assert_eq!(c.get("schedule").unwrap(), "round_robin");
        assert_eq!(c.get("max_staleness").unwrap(), "-");
        c.set("per-frame", "3").unwrap();
        c.set("schedule", "priority").unwrap();
        let SolverChoice::Dispersive(o) = c else {
            unreachable!()
        };
        assert_eq!(
            o.schedule,
            Schedule::Priority {
                per_frame: 3,
                max_staleness: DEFAULT_MAX_STALENESS
            }
        );
        c.set_all(&[("budget_ms", "7.5"), ("schedule", "budget")])
            .unwrap();
        let SolverChoice::Dispersive(o) = c else {
            unreachable!()
        };
        assert_eq!(
            o.schedule,
            Schedule::Budget {
                ms: 7.5,
                max_staleness: DEFAULT_MAX_STALENESS
            }
        );
        assert!(!c.key("budget_ms").unwrap().rebuilds);
        assert!(c.key("cube_res").unwrap().rebuilds);
    }

    #[test]
    fn describe_lists_defaults_per_preset() {
        let table = describe("dispersive").unwrap();
        let cube = table.iter().find(|k| k.name == "cube_res").unwrap();
        assert_eq!(
            cube.defaults,
            vec![("default", "32".to_string()), ("paper", "128".to_string())]
        );
        let margin = table.iter().find(|k| k.name == "probe_margin").unwrap();
        assert_eq!(margin.defaults[0].1, "0.01");
        assert_eq!(describe("grid").unwrap().len(), GRID_KEYS.len());
        assert!(describe("nope").is_err());
    }
}
