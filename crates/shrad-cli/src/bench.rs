//! The `shrad bench` command: runs `shrad::bench`, writes results.json, results.md, the
//! plots (PNG through plotters, with the DejaVu font found at run time; CSV always) and a
//! progress bar over the whole run.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use shrad::bench::{BenchOptions, BenchReport, Record, SolverKind, Table};

/// Options of `shrad bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Only the row nearest 75k patches (a few minutes).
    #[arg(long)]
    pub quick: bool,
    /// Output directory.
    #[arg(long)]
    pub out: std::path::PathBuf,
    /// Reference solver: form-factor rays per patch (fewer than `render`'s 256 to fit the
    /// run in 30 minutes).
    #[arg(long, default_value_t = 128)]
    pub rays_per_patch: u32,
    /// Only these scenes (comma-separated names, e.g. room-12k,big-18.5k-280).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Only these solvers (comma-separated: grid5, grid4, grid5-r32, dispersive, paper).
    #[arg(long, value_delimiter = ',')]
    pub solvers: Vec<String>,
    /// Override every scene's target patch count (smoke tests; not the paper's sizes).
    #[arg(long, hide = true)]
    pub patches: Option<usize>,
    /// No progress bar and no informational lines (errors and warnings still print).
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run the benchmark.
pub fn cmd_bench(args: BenchArgs) -> Result<()> {
    if args.rays_per_patch == 0 {
        anyhow::bail!("--rays-per-patch must be at least 1");
    }
    let mut options = BenchOptions::new(args.quick);
    options.reference.rays_per_patch = args.rays_per_patch;
    if !args.scenes.is_empty() {
        let all = shrad::bench::scenes(false);
        options.scenes = Vec::new();
        for name in &args.scenes {
            let spec = all.iter().find(|s| &s.name == name).with_context(|| {
                let names: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
                format!("unknown scene {name}; known: {}", names.join(", "))
            })?;
            options.scenes.push(spec.clone());
        }
    }
    if !args.solvers.is_empty() {
        let all = SolverKind::ALL;
        options.solvers = Vec::new();
        for name in &args.solvers {
            let kind = all.iter().find(|k| k.label() == name).with_context(|| {
                let names: Vec<&str> = all.iter().map(|k| k.label()).collect();
                format!(
                    "--solvers: unknown solver {name}; known: {}",
                    names.join(", ")
                )
            })?;
            if !options.solvers.contains(kind) {
                options.solvers.push(*kind);
            }
        }
        // grid5 sets the same-time budget of the others: it runs first when present.
        options
            .solvers
            .sort_by_key(|k| all.iter().position(|a| a == k));
    }
    if let Some(n) = args.patches {
        if !(100..=10_000_000).contains(&n) {
            anyhow::bail!("--patches must be between 100 and 10000000, got {n}");
        }
        for spec in &mut options.scenes {
            spec.params.patches = n;
            if let Some(b) = spec.params.big_object_patches.as_mut() {
                *b = (*b).min(n / 2);
            }
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create directory", args.out.display()))?;
    let command = std::env::args()
        .map(|a| if a.contains(' ') { format!("'{a}'") } else { a })
        .collect::<Vec<_>>()
        .join(" ");
    let quiet = args.quiet;
    if !quiet {
        let embree = shrad::vis::available_backends().contains(&shrad::vis::Backend::Embree);
        let name = if embree { "embree" } else { "bvh" };
        eprintln!(
            "visibility: {}",
            crate::describe_backend(name, crate::BackendArg::Auto)
        );
        eprintln!(
        "shrad bench: {} scenes x {} solvers; reference with {} rays per patch; grids: {} warm-up + {} timed frames; dispersive: {} warm-up + {} timed passes (1 pass = 1 frame per interior object)",
        options.scenes.len(),
        options.solvers.len(),
        options.reference.rays_per_patch,
        options.grid_warmup,
        options.grid_timed,
        options.dispersive_warmup_passes,
        options.dispersive_timed_passes
    );
    }
    let bar = crate::progress::Bars::with_template(
        "{msg} [{bar:40}] {pos}/{len} steps ({elapsed}, eta {eta})",
    );
    let report = if quiet {
        shrad::bench::run(&options, &shrad::NoProgress, &|_| {})?
    } else {
        shrad::bench::run(&options, &bar, &|line| bar.println(line))?
    };
    // results.json: the four solvers of the schema; report.json: everything.
    let listed: Vec<&Record> = report
        .records
        .iter()
        .filter(|r| SolverKind::in_results_json(&r.solver))
        .collect();
    write(
        &args.out.join("results.json"),
        &serde_json::to_string_pretty(&listed)?,
    )?;
    write(
        &args.out.join("report.json"),
        &serde_json::to_string_pretty(&report)?,
    )?;
    let mut md = shrad::bench::markdown(&report, &command);
    let plots = write_plots(&report, &args.out)?;
    md.push_str("\n## Plots\n\n");
    md.push_str(&plots);
    write(&args.out.join("results.md"), &md)?;
    if quiet {
        return Ok(());
    }
    eprintln!(
        "{}",
        shrad::bench::markdown(&report, &command)
            .lines()
            .take_while(|l| !l.starts_with("## Every"))
            .collect::<Vec<_>>()
            .join("\n")
    );
    eprintln!(
        "wrote results.json, results.md, plots to {} ({:.0} s)",
        args.out.display(),
        report.seconds
    );
    Ok(())
}

fn write(path: &Path, text: &str) -> Result<()> {
    // Written aside and renamed, like every output: never a half-written file.
    shrad::image_io::write_atomic(path, |tmp| {
        std::fs::write(tmp, text).map_err(|e| e.to_string())
    })?;
    Ok(())
}

/// One colour per solver, the same in every plot.
fn colour_of(solver: &str) -> plotters::style::RGBColor {
    use plotters::style::RGBColor;
    match solver {
        "grid4" => RGBColor(230, 120, 0),
        "grid5" => RGBColor(30, 60, 200),
        "grid5-r32" => RGBColor(100, 170, 230),
        "dispersive" => RGBColor(200, 0, 120),
        "paper" => RGBColor(40, 150, 40),
        _ => RGBColor(90, 90, 90),
    }
}

/// A series of one solver: (x, y) points.
struct Series {
    name: String,
    points: Vec<(f64, f64)>,
}

const SOLVERS: [&str; 5] = ["grid4", "grid5", "grid5-r32", "dispersive", "paper"];

fn series_by_solver(
    records: &[&Record],
    x: fn(&Record) -> f64,
    y: fn(&Record) -> f64,
) -> Vec<Series> {
    SOLVERS
        .iter()
        .map(|&s| {
            let mut points: Vec<(f64, f64)> = records
                .iter()
                .filter(|r| r.solver == s)
                .map(|r| (x(r), y(r)))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                name: s.into(),
                points,
            }
        })
        .filter(|s| !s.points.is_empty())
        .collect()
}

/// Write the plot data as CSV and, when a font is found, as PNG. Returns Markdown lines.
fn write_plots(report: &BenchReport, out: &Path) -> Result<String> {
    let mut md = String::new();
    let scaling: Vec<&Record> = report
        .records
        .iter()
        .filter(|r| r.table == Table::Scaling)
        .collect();
    let big: Vec<&Record> = report
        .records
        .iter()
        .filter(|r| r.table == Table::BigObject)
        .collect();
    let mut plots: Vec<(String, String, String, String, Vec<Series>, bool)> = Vec::new();
    if !scaling.is_empty() {
        plots.push((
            "time_vs_patches".into(),
            "Time per frame against patches (Figure 2; 8 objects)".into(),
            "patches".into(),
            "frame time (ms)".into(),
            series_by_solver(&scaling, |r| r.patches as f64, |r| r.frame_ms_median),
            true,
        ));
    }
    if !big.is_empty() {
        plots.push((
            "time_vs_object_patches".into(),
            "Time per frame against the largest object's patches (Figure 3)".into(),
            "patches of the largest object".into(),
            "frame time (ms)".into(),
            series_by_solver(
                &big,
                |r| r.largest_object_patches as f64,
                // The paper's Figure 3: the frame that updates the grown object.
                |r| {
                    if r.largest_object_frame_ms.is_finite() {
                        r.largest_object_frame_ms
                    } else {
                        r.frame_ms_median
                    }
                },
            ),
            true,
        ));
    }
    // Error against solver time: one plot per Tables 1-2 scene nearest 75k patches, and the
    // largest scene.
    let mut scenes: Vec<(&str, usize)> = report
        .scenes
        .iter()
        .filter(|s| {
            report
                .records
                .iter()
                .any(|r| r.scene == s.scene && r.table == Table::Scaling)
        })
        .map(|s| (s.scene.as_str(), s.patches))
        .collect();
    scenes.sort_by_key(|s| (s.1 as i64 - 75_000).abs());
    let mut error_scenes: Vec<&str> = scenes.iter().take(1).map(|s| s.0).collect();
    if let Some(l) = report.scenes.iter().max_by_key(|s| s.patches) {
        if !error_scenes.contains(&l.scene.as_str()) {
            error_scenes.push(&l.scene);
        }
    }
    for scene in error_scenes {
        let series = SOLVERS
            .iter()
            .filter_map(|&s| {
                let r = report
                    .records
                    .iter()
                    .find(|r| r.scene == scene && r.solver == s)?;
                Some(Series {
                    name: s.into(),
                    points: r
                        .trace
                        .iter()
                        .filter(|t| t.ms > 0.0 && t.error.is_finite())
                        .map(|t| (t.ms, 100.0 * t.error))
                        .collect(),
                })
            })
            .collect();
        plots.push((
            format!("error_vs_time_{scene}"),
            format!("Error against solver time, {scene}"),
            "summed frame time (ms)".into(),
            "relative L2 error (%)".into(),
            series,
            false,
        ));
    }
    let font = load_font();
    if font.is_none() {
        eprintln!(
            "warning: no TrueType font found (looked for DejaVuSans): PNG plots without text"
        );
    }
    for (name, title, xl, yl, series, log_y) in &plots {
        let csv = out.join(format!("{name}.csv"));
        let mut text = format!("series,{xl},{yl}\n");
        for s in series {
            for (x, y) in &s.points {
                text.push_str(&format!("{},{x},{y}\n", s.name));
            }
        }
        write(&csv, &text)?;
        let png = out.join(format!("{name}.png"));
        match plot_png(&png, title, xl, yl, series, *log_y, font.is_some()) {
            Ok(()) => md.push_str(&format!("- ![{title}]({name}.png) (data: {name}.csv)\n")),
            Err(e) => {
                eprintln!(
                    "warning: {}: plot failed ({e}); the data is in {}",
                    png.display(),
                    csv.display()
                );
                md.push_str(&format!("- {title}: {name}.csv (PNG failed: {e})\n"));
            }
        }
    }
    Ok(md)
}

/// Register a sans-serif font with plotters; false when none is found.
fn load_font() -> Option<()> {
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
                return Some(());
            }
        }
    }
    None
}

fn plot_png(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    linear_x: bool,
    text: bool,
) -> Result<()> {
    use plotters::prelude::*;
    let (w, h) = (900u32, 600u32);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
        let pts = series.iter().flat_map(|s| s.points.iter());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if x0 > x1 {
            anyhow::bail!("no data");
        }
        let y0 = (y0 * 0.8).max(1e-3);
        let y1 = (y1 * 1.25).max(y0 * 2.0);
        let mut builder = ChartBuilder::on(&root);
        builder.margin(15);
        if text {
            builder
                .caption(title, ("sans-serif", 22))
                .x_label_area_size(45)
                .y_label_area_size(70);
        }
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart;
                let mut mesh = chart.configure_mesh();
                if text {
                    mesh.x_desc(x_label).y_desc(y_label);
                } else {
                    mesh.disable_x_axis().disable_y_axis();
                }
                mesh.draw().map_err(|e| anyhow::anyhow!("{e}"))?;
                for s in series {
                    let c = colour_of(&s.name);
                    let drawn = chart
                        .draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(2)))
                        .map_err(|e| anyhow::anyhow!("{e}"))?;
                    if text {
                        drawn.label(s.name.as_str()).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                        });
                    }
                    chart
                        .draw_series(s.points.iter().map(|&p| Circle::new(p, 3, c.filled())))
                        .map_err(|e| anyhow::anyhow!("{e}"))?;
                }
                if text {
                    chart
                        .configure_series_labels()
                        .background_style(WHITE.mix(0.8))
                        .border_style(BLACK)
                        .position(SeriesLabelPosition::UpperLeft)
                        .draw()
                        .map_err(|e| anyhow::anyhow!("{e}"))?;
                }
            }};
        }
        if linear_x {
            let x_pad = 0.05 * (x1 - x0).max(1.0);
            draw!(builder
                .build_cartesian_2d((x0 - x_pad)..(x1 + x_pad), (y0..y1).log_scale())
                .map_err(|e| anyhow::anyhow!("{e}"))?);
        } else {
            let x0 = (x0 * 0.8).max(1e-3);
            let x1 = (x1 * 1.25).max(x0 * 2.0);
            draw!(builder
                .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                .map_err(|e| anyhow::anyhow!("{e}"))?);
        }
        root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    shrad::image_io::write_atomic(path, |tmp| {
        image::save_buffer(tmp, &buf, w, h, image::ExtendedColorType::Rgb8)
            .map_err(|e| e.to_string())
    })?;
    Ok(())
}
