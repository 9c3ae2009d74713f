//! The plots of a run: the paper's Figures 2 and 3 (time per frame against patches), the
//! moving frame against the number of objects (`time_vs_objects`) and the error against
//! solver time, each as CSV (through the `csv` crate, always) and PNG
//! (plotters, with a DejaVu/Liberation/FreeSans font found at run time; without one the
//! picture has no text and a warning says so). One series per [`SolverKind`], in its colour.

use std::path::{Path, PathBuf};

use shrad::Error;

use crate::report::{BenchReport, Record};
use crate::scenes::Table;
use crate::solvers::SolverKind;

/// One solver's (x, y) points, sorted by x.
#[derive(Clone, Debug)]
pub struct Series {
    /// The solver.
    pub solver: SolverKind,
    /// The points.
    pub points: Vec<(f64, f64)>,
}

/// How the x axis is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum XAxis {
    /// Linear (patch counts).
    Linear,
    /// Logarithmic (summed time).
    Log,
}

/// One plot: a file name (without extension), its labels and its series. The y axis is
/// logarithmic.
#[derive(Clone, Debug)]
pub struct Plot {
    /// File stem of the `.csv` and `.png`.
    pub name: String,
    /// Title.
    pub title: String,
    /// x-axis label (and CSV column).
    pub x_label: String,
    /// y-axis label (and CSV column).
    pub y_label: String,
    /// One series per solver with points.
    pub series: Vec<Series>,
    /// The x axis.
    pub x_axis: XAxis,
}

fn series_by_solver(
    records: &[&Record],
    x: fn(&Record) -> f64,
    y: fn(&Record) -> f64,
) -> Vec<Series> {
    SolverKind::ALL
        .into_iter()
        .map(|solver| {
            let mut points: Vec<(f64, f64)> = records
                .iter()
                .filter(|r| r.solver == solver)
                .map(|r| (x(r), y(r)))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series { solver, points }
        })
        .filter(|s| !s.points.is_empty())
        .collect()
}

/// The records that timed a moving object.
fn moving<'a>(records: &[&'a Record]) -> Vec<&'a Record> {
    records
        .iter()
        .copied()
        .filter(|r| r.moving.is_some())
        .collect()
}

/// The moving frame against the number of interior objects (the objects scenes' records
/// with a moving window); None without any.
fn objects_plot(records: &[&Record]) -> Option<Plot> {
    (!records.is_empty()).then(|| Plot {
        name: "time_vs_objects".into(),
        title: "Moving frame against interior objects (40k patches, one small box moving)".into(),
        x_label: "interior objects".into(),
        y_label: "moving frame time (ms)".into(),
        series: series_by_solver(
            records,
            |r| r.interior_objects as f64,
            |r| r.moving.as_ref().map_or(f64::NAN, |m| m.frame_ms_median),
        ),
        x_axis: XAxis::Log,
    })
}

/// The plots of `report`: the paper's Figure 3 (every solver on the Tables 1-2 scenes), its
/// Figure 2 (its Table 3 plotted: the Table 3 scenes), and the error against time on the
/// Tables 1-2 scene nearest 75k patches and on the largest scene.
pub fn plots(report: &BenchReport) -> Vec<Plot> {
    let of =
        |t: Table| -> Vec<&Record> { report.records.iter().filter(|r| r.table == t).collect() };
    let (scaling, big) = (of(Table::Scaling), of(Table::BigObject));
    let mut plots = Vec::new();
    if !scaling.is_empty() {
        plots.push(Plot {
            name: "time_vs_patches".into(),
            title: "Time per frame against patches (paper's Figure 3; 8 objects)".into(),
            x_label: "patches".into(),
            y_label: "frame time (ms)".into(),
            series: series_by_solver(&scaling, |r| r.patches as f64, |r| r.frame_ms_median),
            x_axis: XAxis::Linear,
        });
        plots.push(Plot {
            name: "time_vs_patches_moving".into(),
            title: "Time per frame against patches, one object moving every frame".into(),
            x_label: "patches".into(),
            y_label: "frame time (ms)".into(),
            series: series_by_solver(
                &moving(&scaling),
                |r| r.patches as f64,
                |r| r.moving.as_ref().map_or(f64::NAN, |m| m.frame_ms_median),
            ),
            x_axis: XAxis::Linear,
        });
    }
    plots.extend(objects_plot(&moving(&of(Table::Objects))));
    if !big.is_empty() {
        plots.push(Plot {
            name: "time_vs_object_patches".into(),
            title: "Time per frame against the largest object's patches (paper's Figure 2)".into(),
            x_label: "patches of the largest object".into(),
            y_label: "frame time (ms)".into(),
            series: series_by_solver(
                &big,
                |r| r.largest_object_patches as f64,
                // The paper's Figure 2 (Table 3): the frame that updates the grown object.
                |r| {
                    if r.largest_object_frame_ms.is_finite() {
                        r.largest_object_frame_ms
                    } else {
                        r.frame_ms_median
                    }
                },
            ),
            x_axis: XAxis::Linear,
        });
    }
    let mut near_75k: Vec<(&str, usize)> = report
        .scenes_of(Table::Scaling)
        .iter()
        .map(|s| (s.scene.as_str(), s.patches))
        .collect();
    near_75k.sort_by_key(|s| (s.1 as i64 - 75_000).abs());
    let mut error_scenes: Vec<&str> = near_75k.iter().take(1).map(|s| s.0).collect();
    if let Some(l) = report.scenes.iter().max_by_key(|s| s.patches) {
        if !error_scenes.contains(&l.scene.as_str()) {
            error_scenes.push(&l.scene);
        }
    }
    for scene in error_scenes {
        let series = SolverKind::ALL
            .into_iter()
            .filter_map(|solver| {
                let r = report.find(scene, solver)?;
                Some(Series {
                    solver,
                    points: r
                        .trace
                        .iter()
                        .filter(|t| t.ms > 0.0 && t.error.is_finite())
                        .map(|t| (t.ms, 100.0 * t.error))
                        .collect(),
                })
            })
            .collect();
        plots.push(Plot {
            name: format!("error_vs_time_{scene}"),
            title: format!("Error against solver time, {scene}"),
            x_label: "summed frame time (ms)".into(),
            y_label: "relative L2 error (%)".into(),
            series,
            x_axis: XAxis::Log,
        });
    }
    plots
}

/// Write `plot`'s data to `path` (columns `series`, x label, y label), atomically.
pub fn write_csv(plot: &Plot, path: &Path) -> Result<(), Error> {
    shrad::image_io::write_atomic(path, |tmp| {
        let mut w = csv::Writer::from_path(tmp).map_err(|e| e.to_string())?;
        w.write_record(["series", &plot.x_label, &plot.y_label])
            .map_err(|e| e.to_string())?;
        for s in &plot.series {
            for (x, y) in &s.points {
                w.write_record([s.solver.label(), &x.to_string(), &y.to_string()])
                    .map_err(|e| e.to_string())?;
            }
        }
        w.flush().map_err(|e| e.to_string())
    })
    .map_err(Error::from)
}

/// Register a sans-serif font with plotters; false when none is found.
pub fn load_font() -> bool {
    let candidates: Vec<PathBuf> = [
        "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/TTF/DejaVuSans.ttf",
        "/usr/share/fonts/dejavu/DejaVuSans.ttf",
        "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
        "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    ]
    .iter()
    .map(PathBuf::from)
    .collect();
    for path in candidates {
        if let Ok(bytes) = std::fs::read(&path) {
            // plotters keeps fonts for the process's lifetime.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font(
                "sans-serif",
                plotters::style::FontStyle::Normal,
                bytes,
            )
            .is_ok()
            {
                return true;
            }
        }
    }
    false
}

/// The smallest and largest x and y of `plot`'s points; `None` without a point.
fn data_range(plot: &Plot) -> Option<(f64, f64, f64, f64)> {
    let points = plot.series.iter().flat_map(|s| s.points.iter());
    let range = points.fold((f64::MAX, f64::MIN, f64::MAX, f64::MIN), |r, &(x, y)| {
        (r.0.min(x), r.1.max(x), r.2.min(y), r.3.max(y))
    });
    (range.0 <= range.1).then_some(range)
}

/// An axis number as short as it can be ("100", not "100.0"): a log axis puts its labels
/// close together near a decade's end, where the long ones ran into each other.
fn short_number(v: &f64) -> String {
    match *v >= 1.0 && v.fract() == 0.0 {
        true => format!("{v:.0}"),
        false => format!("{v}"),
    }
}

/// Draw `plot` as a 900 x 600 PNG at `path` (atomically); `text`: a font is registered.
pub fn write_png(plot: &Plot, path: &Path, text: bool) -> Result<(), String> {
    use plotters::prelude::*;
    let fail = |e: &dyn std::fmt::Display| e.to_string();
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(&e))?;
        let (x0, x1, y0, y1) = data_range(plot).ok_or("no data")?;
        let y0 = (y0 * 0.8).max(1e-3);
        let y1 = (y1 * 1.25).max(y0 * 2.0);
        let mut builder = ChartBuilder::on(&root);
        builder.margin(15);
        if text {
            builder
                .caption(&plot.title, ("sans-serif", 22))
                .x_label_area_size(45)
                .y_label_area_size(70);
        }
        // The two axis kinds are two chart types: one body for both.
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart;
                let mut mesh = chart.configure_mesh();
                if text {
                    mesh.x_desc(&plot.x_label)
                        .y_desc(&plot.y_label)
                        .x_label_formatter(&short_number)
                        .y_label_formatter(&short_number);
                } else {
                    mesh.disable_x_axis().disable_y_axis();
                }
                mesh.draw().map_err(|e| fail(&e))?;
                for s in &plot.series {
                    let (r, g, b) = s.solver.colour();
                    let c = RGBColor(r, g, b);
                    let drawn = chart
                        .draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(2)))
                        .map_err(|e| fail(&e))?;
                    if text {
                        drawn.label(s.solver.label()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                        });
                    }
                    chart
                        .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, c.filled())))
                        .map_err(|e| fail(&e))?;
                }
                if text {
                    chart
                        .configure_series_labels()
                        .background_style(WHITE.mix(0.8))
                        .border_style(BLACK)
                        .position(SeriesLabelPosition::UpperLeft)
                        .draw()
                        .map_err(|e| fail(&e))?;
                }
            }};
        }
        match plot.x_axis {
            XAxis::Linear => {
                let x_pad = 0.05 * (x1 - x0).max(1.0);
                draw!(builder
                    .build_cartesian_2d((x0 - x_pad)..(x1 + x_pad), (y0..y1).log_scale())
                    .map_err(|e| fail(&e))?);
            }
            XAxis::Log => {
                let x0 = (x0 * 0.8).max(1e-3);
                let x1 = (x1 * 1.25).max(x0 * 2.0);
                draw!(builder
                    .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                    .map_err(|e| fail(&e))?);
            }
        }
        root.present().map_err(|e| fail(&e))?;
    }
    shrad::image_io::write_atomic(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            &buf,
            w,
            h,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())
    })
    .map_err(|e| e.to_string())
}
