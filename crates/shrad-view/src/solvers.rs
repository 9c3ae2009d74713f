//! Solver names, presets and settings as the page sees them: a thin layer over the
//! library's settings (`shrad::settings`: one table of keys per solver, validated there).

use serde_json::{json, Map, Value};
use shrad::engine::Engine;
use shrad::settings::{presets, SOLVERS};
use shrad::solver::SolverChoice;

/// The settings of `solver` under `preset` (`default`: the solver's default preset).
pub fn choice(solver: &str, preset: &str) -> Result<SolverChoice, String> {
    SolverChoice::preset(solver, preset).map_err(|e| e.to_string())
}

/// Every solver's presets, default first: `{"dispersive": ["default", "paper"], ...}`.
pub fn presets_json() -> Value {
    let mut m = Map::new();
    for s in SOLVERS {
        let list: Vec<&str> = presets(s).map(|p| p.to_vec()).unwrap_or_default();
        m.insert(s.to_string(), json!(list));
    }
    Value::Object(m)
}

/// Change one setting of the solver in use by name. Keys that need precomputation rebuild
/// the solver (the reply says what that cost); the schedule's keys change live.
pub fn set_option(engine: &mut Engine, key: &str, value: &str) -> Result<Value, String> {
    let rebuilt = engine.set_option(key, value).map_err(|e| e.to_string())?;
    Ok(json!({
        "key": key,
        "value": engine.option(key).unwrap_or_default(),
        "precompute_ms": rebuilt.map(|r| r.precompute_ms),
    }))
}

/// The largest values the viewer takes for the settings that make a frame or its rebuild
/// cost seconds and gigabytes (one `set_option` of `cube_res` 2048 held 4-10 GB and made
/// every frame take 10 s for every client; `direct_samples` 65536 blocked every client for
/// 6.5 s and made each move 0.7 s on a 2,000-patch box, `near_rays` 65536 took 665 MB):
/// about 16x the defaults' rays. `shrad render --set` takes the library's whole range.
pub const INTERACTIVE_MAX: [(&str, u64); 9] = [
    ("cube_res", 256),
    ("emitter_res", 256),
    ("per_axis", 8),
    ("wall_rays", 1024),
    ("direct_samples", 1024),
    ("self_shadow_rays", 1024),
    ("near_rays", 1024),
    ("contact_rays", 256),
    ("rays_per_patch", 4096),
];

/// Refuse a value of `key` beyond [`INTERACTIVE_MAX`] (what is not a number is the
/// settings' own check's to refuse).
pub fn interactive(key: &str, value: &str) -> Result<(), String> {
    let Some(&(_, most)) = INTERACTIVE_MAX.iter().find(|(k, _)| *k == key) else {
        return Ok(());
    };
    match value.trim().parse::<f64>() {
        Ok(v) if v > most as f64 => Err(format!(
            "{key} {value}: the viewer takes at most {most} (frames must stay interactive); \
             `shrad render --set {key}=...` takes more"
        )),
        _ => Ok(()),
    }
}

/// Every setting of the solver in use, as text (`-` for a schedule parameter the schedule
/// in force does not use).
pub fn settings(engine: &Engine) -> Value {
    let choice = engine.solver_choice();
    let mut m = Map::new();
    for spec in choice.keys() {
        if let Ok(v) = choice.get(spec.name) {
            m.insert(spec.name.to_string(), json!(v));
        }
    }
    Value::Object(m)
}
