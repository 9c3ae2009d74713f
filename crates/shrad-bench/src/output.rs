//! Everything a run writes into its output directory: `results.json` (the four
//! solvers), `report.json` (everything), `results.md` (the tables and the plots' list) and
//! the plots (CSV and PNG). Every file is written aside and renamed: never half-written.

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
