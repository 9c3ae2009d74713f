//! Everything a run writes into its output directory: `results.json` (the four
//! solvers), `report.json` (everything), `results.md` (the tables and the plots' list),
//! `moving.csv` (one row per record with a moving window: its frame, steps, error while
//! moving and ray floor) and the plots (CSV and PNG). Every file is written aside and renamed: never half-written.

use std::path::Path;

use shrad::Error;

use crate::plots::{load_font, plots, write_csv, write_png};
use crate::report::{BenchReport, Record};

fn write_text(path: &Path, text: &str) -> Result<(), Error> {
    shrad::image_io::write_atomic(path, |tmp| {
        std::fs::write(tmp, text).map_err(|e| e.to_string())
    })
    .map_err(Error::from)
}

fn to_json<T: serde::Serialize + ?Sized>(value: &T) -> Result<String, Error> {
    serde_json::to_string_pretty(value).map_err(|e| Error::Invalid(format!("JSON: {e}")))
}

/// The columns of `moving.csv`.
const MOVING_COLUMNS: [&str; 22] = [
    "scene",
    "table",
    "solver",
    "patches",
    "interior_objects",
    "object",
    "object_patches",
    "frames",
    "frame_ms_median",
    "frame_ms_max",
    "direct_ms",
    "objects_ms",
    "to_boundary_ms",
    "assemble_ms",
    "error_overall",
    "error_boundary",
    "error_interior",
    "rays_median",
    "ray_floor_ms",
    "over_ray_floor",
    "speedup_vs_grid5",
    "speedup_vs_grid5_r32",
];

/// One row of `moving.csv` per record with a moving window (errors as fractions; an
/// absent speed-up is empty).
fn moving_rows(report: &BenchReport) -> Vec<Vec<String>> {
    let opt = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
    report
        .records
        .iter()
        .filter_map(|r| r.moving.as_ref().map(|m| (r, m)))
        .map(|(r, m)| {
            vec![
                r.scene.clone(),
                format!("{:?}", r.table),
                r.solver.label().to_string(),
                r.patches.to_string(),
                r.interior_objects.to_string(),
                m.object.clone(),
                m.object_patches.to_string(),
                m.frames.to_string(),
                m.frame_ms_median.to_string(),
                m.frame_ms_max.to_string(),
                m.step_ms.direct.to_string(),
                m.step_ms.objects.to_string(),
                m.step_ms.to_boundary.to_string(),
                m.step_ms.assemble.to_string(),
                m.error.overall.to_string(),
                m.error.boundary.to_string(),
                m.error.interior.to_string(),
                m.rays_median.to_string(),
                m.ray_floor_ms.to_string(),
                m.over_ray_floor.to_string(),
                opt(m.speedup_vs_grid5),
                opt(m.speedup_vs_grid5_r32),
            ]
        })
        .collect()
}

/// Write `moving.csv` to `path`, atomically.
fn write_moving_csv(report: &BenchReport, path: &Path) -> Result<(), Error> {
    shrad::image_io::write_atomic(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).map_err(|e| e.to_string())?;
        w.write_record(MOVING_COLUMNS).map_err(|e| e.to_string())?;
        for row in moving_rows(report) {
            w.write_record(&row).map_err(|e| e.to_string())?;
        }
        w.flush().map_err(|e| e.to_string())
    })
    .map_err(Error::from)
}

/// Write the run's files into `dir` (which must exist); `command` is recorded in
/// `results.md`. `warn` receives what went wrong without stopping the run (a PNG that could
/// not be drawn, no font); the CSV of a failed plot is still written.
pub fn write_outputs(
    report: &BenchReport,
    dir: &Path,
    command: &str,
    warn: &dyn Fn(&str),
) -> Result<(), Error> {
    let listed: Vec<&Record> = report
        .records
        .iter()
        .filter(|r| r.solver.in_results_json())
        .collect();
    write_text(&dir.join("results.json"), &to_json(&listed)?)?;
    write_text(&dir.join("report.json"), &to_json(report)?)?;
    write_moving_csv(report, &dir.join("moving.csv"))?;
    let mut md = crate::markdown(report, command);
    md.push_str("\n## Plots\n\n");
    let font = load_font();
    if !font {
        warn("no TrueType font found (looked for DejaVuSans): PNG plots without text");
    }
    for plot in plots(report) {
        let (name, title) = (&plot.name, &plot.title);
        let csv = dir.join(format!("{name}.csv"));
        write_csv(&plot, &csv)?;
        let png = dir.join(format!("{name}.png"));
        match write_png(&plot, &png, font) {
            Ok(()) => md.push_str(&format!("- ![{title}]({name}.png) (data: {name}.csv)\n")),
            Err(e) => {
                warn(&format!(
                    "{}: plot failed ({e}); the data is in {}",
                    png.display(),
                    csv.display()
                ));
                md.push_str(&format!("- {title}: {name}.csv (PNG failed: {e})\n"));
            }
        }
    }
    write_text(&dir.join("results.md"), &md)
}
