//! Tests of the settings: presets, ranges, the flattened schedule, listings.

use super::keys::DEFAULT_MAX_STALENESS;
use super::*;
use crate::dispersive::Schedule;

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
fn a_choice_knows_its_preset_until_a_setting_differs() {
    for s in SOLVERS {
        for p in presets(s).unwrap() {
            let choice = SolverChoice::preset(s, p).unwrap();
            assert_eq!(choice.preset_name(), Some(*p), "{s} {p}");
        }
    }
    let mut c = SolverChoice::preset("dispersive", "default").unwrap();
    c.set("per_frame", "7").unwrap();
    assert_eq!(c.preset_name(), None);
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
        ("repair", "move", "none|drop|move_inward|move_out"),
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
