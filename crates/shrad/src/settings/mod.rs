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

mod keyed;
mod keys;
#[cfg(test)]
mod tests;

use std::fmt;

use crate::dispersive::DispersiveOptions;
use crate::grid::GridOptions;
use crate::reference::ReferenceOptions;
use crate::solver::SolverChoice;
use crate::Error;

pub use keys::{DISPERSIVE_KEYS, GRID_KEYS, REFERENCE_KEYS};

use keyed::Keyed;

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

    /// The preset these settings are, if they are one ([`presets`] of [`SolverChoice::name`],
    /// the default first); `None` once a setting differs from every preset.
    pub fn preset_name(&self) -> Option<&'static str> {
        let list = presets(self.name()).ok()?;
        list.iter()
            .copied()
            .find(|p| SolverChoice::preset(self.name(), p).is_ok_and(|c| c == *self))
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
