//! The `shrad` command line: parses options, loads the scene and calls the library.
//! It holds no algorithm.

mod bench;
mod progress;
mod settings;

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{ArgMatches, Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use shrad::dispersive::{DispersiveOptions, ProbeRepair, Schedule, ToBoundary};
use shrad::grid::GridOptions;
use shrad::image_io::{write_exr, write_png, Tonemap};
use shrad::reference::ReferenceOptions;
use shrad::render::{render, RenderOptions, Shading};
use shrad::solver::SolverChoice;
use shrad::{PatchSizing, Progress, World};
use shrad_scene::{LoadOptions, Scene};

/// Global illumination (radiosity) for dynamic scenes: the dispersive SH method of Wang, Liu
/// and Wu (2007), its probe-grid baseline and a converged reference solver.
#[derive(Parser)]
#[command(name = "shrad", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Solve a scene and write a picture (PNG, optionally linear EXR and patch CSV).
    Render(RenderArgs),
    /// Print what a scene contains: objects, roles, materials, patches.
    Info(InfoArgs),
    /// Run an animated scene frame by frame: a PNG per frame, a GIF (and MP4 when ffmpeg is
    /// installed) and DIR/stats.csv with the paper's Table 3 columns and the error.
    Animate(AnimateArgs),
    /// Reproduce the paper's Tables 1-3 and Figures 2-3 in one run: grid (G = 4, 5) and
    /// dispersive (default and paper preset) on the same scenes, times, memory and error.
    Bench(bench::BenchArgs),
}

#[derive(Args)]
struct AnimateArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    solver: SolverArgs,
    /// Number of frames [default: all of the scene's animation (duration x fps + 1), or 120
    /// for a scene that does not move].
    #[arg(long)]
    frames: Option<usize>,
    /// Frames per second of scene time (frame f shows time f / fps).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    fps: f32,
    /// Output directory (created if missing).
    #[arg(short, long)]
    output: PathBuf,
    /// Fill the error column (spec 8, against the reference solution of that frame's
    /// geometry) every K frames; 0: never.
    #[arg(long, default_value_t = 0)]
    error_every: usize,
    /// Passes over the objects before frame 0 (a converged start); 0: start from dark.
    #[arg(long, default_value_t = 4)]
    warmup: usize,
    /// Image width in pixels.
    #[arg(long, default_value_t = 320)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 320)]
    height: u32,
    /// Samples (primary rays) per pixel.
    #[arg(long, default_value_t = 1)]
    spp: u32,
    /// Exposure scale [default: auto from the middle frame, the same for every frame].
    #[arg(long, allow_negative_numbers = true)]
    exposure: Option<f32>,
    /// Also write each frame's linear radiance as OpenEXR (DIR/frame_NNNN.exr).
    #[arg(long)]
    hdr: bool,
}

/// Options shared by every command that loads a scene.
#[derive(Args, Clone)]
struct SceneArgs {
    /// Scene: a .gltf, .glb, .obj or .toml file, or a built-in name (cornell, room).
    scene: String,
    /// Patch edge length in scene units [default: the scene file's, else --patches].
    #[arg(long, conflicts_with = "patches", allow_negative_numbers = true)]
    patch_size: Option<f32>,
    /// Target total patch count [default: the scene file's, else 20000].
    #[arg(long)]
    patches: Option<usize>,
    /// Skip zero-area triangles (with a warning) instead of rejecting the file.
    #[arg(long)]
    drop_degenerate: bool,
    /// glTF: play only this animation, by name or index [default: every animation of the
    /// file at once, on one timeline].
    #[arg(long, value_name = "NAME|INDEX")]
    animation: Option<String>,
    /// Visibility backend.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    backend: BackendArg,
    /// No progress bars and no informational lines (errors and warnings still print).
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Clone, Copy, ValueEnum)]
enum BackendArg {
    /// Embree when this build has it, else the pure-Rust BVH.
    Auto,
    /// Intel Embree 3.
    Embree,
    /// Pure-Rust BVH.
    Bvh,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum SolverArg {
    /// Converged radiosity of the patches (ground truth).
    Reference,
    /// The dispersive SH method (Wang, Liu, Wu 2007).
    Dispersive,
    /// The baseline: a uniform grid of SH probes, all updated every frame.
    Grid,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum PresetArg {
    /// shrad's default: the paper plus every measured improvement.
    Default,
    /// The paper as written.
    Paper,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum ScheduleArg {
    /// Objects in order, --per-frame a frame.
    RoundRobin,
    /// By motion and staleness, --per-frame a frame, --max-staleness bound.
    Priority,
    /// As many as fit in --budget-ms.
    Budget,
    /// Every object every frame.
    Full,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum RepairArg {
    /// Keep buried probes.
    None,
    /// Drop them and renormalise the weights.
    Drop,
    /// Move them towards the box centre until valid.
    Move,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
enum ToBoundaryArg {
    /// The paper's cube-map splat.
    Splat,
    /// Per-patch gather with a shadow ray.
    Gather,
    /// Gather on small boundaries, splat on large ones (bounded cost).
    Auto,
}

/// Settings of the dispersive solver; unset ones come from --preset.
#[derive(Args, Clone)]
struct DispersiveArgs {
    /// Starting point for the dispersive settings.
    #[arg(long, value_enum, default_value_t = PresetArg::Default)]
    preset: PresetArg,
    /// Cube-map face resolution of probes [paper: 128, default: 32].
    #[arg(long)]
    cube_res: Option<usize>,
    /// Cube-map face resolution of the Step 3 splat from each object [paper: 128, default: 64].
    #[arg(long)]
    emitter_res: Option<usize>,
    /// SH bands, 1-8 [default: 4 = 16 coefficients].
    #[arg(long)]
    bands: Option<usize>,
    /// Scheduler [paper: round-robin, default: priority].
    #[arg(long, value_enum)]
    schedule: Option<ScheduleArg>,
    /// Objects updated per frame (K) [default: 1].
    #[arg(long)]
    per_frame: Option<usize>,
    /// Staleness bound in frames for priority and budget scheduling [default: 16].
    #[arg(long)]
    max_staleness: Option<usize>,
    /// Per-frame time budget (ms) for --schedule budget [default: 20].
    #[arg(long, allow_negative_numbers = true)]
    budget_ms: Option<f32>,
    /// Buried-probe handling [paper: none, default: move].
    #[arg(long, value_enum)]
    repair: Option<RepairArg>,
    /// Boundary-to-boundary light [paper: false, default: true].
    #[arg(long)]
    wall_exchange: Option<bool>,
    /// Capture probes with the object's own geometry transparent [paper: false, default: true].
    #[arg(long)]
    see_through_self: Option<bool>,
    /// Direct light on interior patches computed explicitly [paper: false, default: true].
    #[arg(long)]
    direct_interior: Option<bool>,
    /// How objects send light to the boundary [paper: splat, default: auto].
    #[arg(long, value_enum)]
    to_boundary: Option<ToBoundaryArg>,
    /// Rays per interior patch detecting faces in contact with other surfaces [paper: 0,
    /// default: 8].
    #[arg(long)]
    contact_rays: Option<u32>,
    /// Step 3 with one emitter per face direction instead of one at the centre [paper:
    /// false, default: true].
    #[arg(long)]
    emitter_per_face: Option<bool>,
    /// Rays per interior patch for transfer vectors with self-visibility (concave objects
    /// shadow and light themselves) [paper: 0, default: 64].
    #[arg(long)]
    self_shadow_rays: Option<u32>,
    /// Spread the Step 3 splat's flux over each hit patch's neighbours, against the
    /// texel pattern [paper: false, default: true].
    #[arg(long)]
    splat_smoothing: Option<bool>,
    /// Probe box margin as a fraction of the box diagonal [paper: 0, default: 0.01].
    #[arg(long, allow_negative_numbers = true)]
    probe_margin: Option<f32>,
}

/// Settings of the grid baseline.
#[derive(Args, Clone)]
struct GridArgs {
    /// Grid solver: probes per axis (paper: 4 and 5).
    #[arg(long, default_value_t = 5)]
    grid: usize,
}

/// Settings of every solver.
#[derive(Args, Clone)]
struct SolverArgs {
    /// Which solver computes the radiosity.
    #[arg(long, value_enum, default_value_t = SolverArg::Reference)]
    solver: SolverArg,
    #[command(flatten)]
    dispersive: DispersiveArgs,
    #[command(flatten)]
    grid: GridArgs,
    /// Reference solver: form-factor rays per patch.
    #[arg(long, default_value_t = ReferenceOptions::standard().rays_per_patch)]
    rays_per_patch: u32,
    /// Reference solver: shadow rays per patch and emitter for direct light.
    #[arg(long, default_value_t = ReferenceOptions::standard().direct_samples)]
    direct_samples: u32,
}

impl SolverArgs {
    fn reference(&self) -> Result<ReferenceOptions> {
        if self.rays_per_patch == 0 || self.direct_samples == 0 {
            bail!("--rays-per-patch and --direct-samples must be at least 1");
        }
        Ok(ReferenceOptions {
            rays_per_patch: self.rays_per_patch,
            direct_samples: self.direct_samples,
            ..ReferenceOptions::standard()
        })
    }
    fn choice(&self) -> Result<SolverChoice> {
        Ok(match self.solver {
            SolverArg::Reference => SolverChoice::Reference(self.reference()?),
            SolverArg::Dispersive => SolverChoice::Dispersive(self.dispersive.options()?),
            SolverArg::Grid => {
                if !(1..=64).contains(&self.grid.grid) {
                    bail!("--grid must be between 1 and 64, got {}", self.grid.grid);
                }
                let mut g = GridOptions::paper(self.grid.grid);
                if let Some(r) = self.dispersive.cube_res {
                    check_range("--cube-res", r, 1, 2048)?;
                    g.cube_res = r;
                }
                if let Some(b) = self.dispersive.bands {
                    check_range("--bands", b, 1, 8)?;
                    g.bands = b;
                }
                SolverChoice::Grid(g)
            }
        })
    }
}

impl DispersiveArgs {
    fn options(&self) -> Result<DispersiveOptions> {
        let mut o = match self.preset {
            PresetArg::Default => DispersiveOptions::improved(),
            PresetArg::Paper => DispersiveOptions::paper(),
        };
        if let Some(r) = self.cube_res {
            if !(1..=2048).contains(&r) {
                bail!("--cube-res must be between 1 and 2048, got {r}");
            }
            o.cube_res = r;
        }
        if let Some(r) = self.emitter_res {
            if !(1..=2048).contains(&r) {
                bail!("--emitter-res must be between 1 and 2048, got {r}");
            }
            o.emitter_res = r;
        }
        if let Some(b) = self.bands {
            if !(1..=8).contains(&b) {
                bail!("--bands must be between 1 and 8, got {b}");
            }
            o.bands = b;
        }
        let k = self.per_frame.unwrap_or(1);
        if k == 0 {
            bail!("--per-frame must be at least 1");
        }
        let max_staleness = self.max_staleness.unwrap_or(16).max(1);
        if let Some(ms) = self.budget_ms {
            check_positive("--budget-ms", ms)?;
        }
        let schedule = self.schedule.unwrap_or(match o.schedule {
            Schedule::RoundRobin { .. } => ScheduleArg::RoundRobin,
            Schedule::Priority { .. } => ScheduleArg::Priority,
            Schedule::Budget { .. } => ScheduleArg::Budget,
            Schedule::Full => ScheduleArg::Full,
        });
        o.schedule = match schedule {
            ScheduleArg::RoundRobin => Schedule::RoundRobin { per_frame: k },
            ScheduleArg::Priority => Schedule::Priority {
                per_frame: k,
                max_staleness,
            },
            ScheduleArg::Budget => Schedule::Budget {
                ms: self.budget_ms.unwrap_or(20.0),
                max_staleness,
            },
            ScheduleArg::Full => Schedule::Full,
        };
        if let Some(r) = self.repair {
            o.repair = match r {
                RepairArg::None => ProbeRepair::None,
                RepairArg::Drop => ProbeRepair::Drop,
                RepairArg::Move => ProbeRepair::MoveInward,
            };
        }
        if let Some(w) = self.wall_exchange {
            o.wall_exchange = w;
        }
        if let Some(s) = self.see_through_self {
            o.see_through_self = s;
        }
        if let Some(d) = self.direct_interior {
            o.direct_on_interior = d;
        }
        if let Some(t) = self.to_boundary {
            o.to_boundary = match t {
                ToBoundaryArg::Splat => ToBoundary::Splat,
                ToBoundaryArg::Gather => ToBoundary::Gather,
                ToBoundaryArg::Auto => ToBoundary::Auto,
            };
        }
        if let Some(r) = self.self_shadow_rays {
            if r > 65536 {
                bail!("--self-shadow-rays must be at most 65536, got {r}");
            }
            o.self_shadow_rays = r;
        }
        if let Some(e) = self.emitter_per_face {
            o.emitter_per_face = e;
        }
        if let Some(b) = self.splat_smoothing {
            o.splat_smoothing = b;
        }
        if let Some(c) = self.contact_rays {
            if c > 4096 {
                bail!("--contact-rays must be at most 4096, got {c}");
            }
            o.contact_rays = c;
        }
        if let Some(m) = self.probe_margin {
            if !(0.0..=1.0).contains(&m) {
                bail!("--probe-margin must be between 0 and 1, got {m}");
            }
            o.probe_margin = m;
        }
        Ok(o)
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum ShadingArg {
    /// Interpolated from patch corners.
    Smooth,
    /// One colour per patch.
    Flat,
}

#[derive(Clone, Copy, ValueEnum)]
enum TonemapArg {
    /// Exposure (auto unless --exposure) and sRGB.
    Exposure,
    /// The paper's linear map of [min, max] to [0, 255].
    Minmax,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    solver: SolverArgs,
    /// Dispersive / grid: frames to run on the (static) scene before drawing
    /// [default: 8 passes over the interior objects, 8 frames for the grid].
    #[arg(long)]
    frames: Option<usize>,
    /// Also solve the reference and print the error of spec section 8 (dispersive / grid).
    #[arg(long)]
    compare: bool,
    /// Scene time in seconds: animated objects and lights are posed at this time, and every
    /// solver solves that pose.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    time: f32,
    /// Output PNG [default: SCENE-NAME.png].
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Also write linear radiance to this OpenEXR file.
    #[arg(long)]
    hdr: Option<PathBuf>,
    /// Also write every patch (object, role, centre, normal, area, radiosity) as CSV.
    #[arg(long)]
    export_patches: Option<PathBuf>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    height: u32,
    /// Samples (primary rays) per pixel.
    #[arg(long, default_value_t = 4)]
    spp: u32,
    /// How radiosity is drawn.
    #[arg(long, value_enum, default_value_t = ShadingArg::Smooth)]
    shading: ShadingArg,
    /// How radiance becomes PNG colour.
    #[arg(long, value_enum, default_value_t = TonemapArg::Exposure)]
    tonemap: TonemapArg,
    /// Exposure scale for --tonemap exposure [default: auto, 99th percentile to 0.9].
    #[arg(long, allow_negative_numbers = true)]
    exposure: Option<f32>,
}

#[derive(Args)]
struct InfoArgs {
    #[command(flatten)]
    scene: SceneArgs,
}

fn main() -> ExitCode {
    let argv: Vec<OsString> = std::env::args_os().collect();
    let matches = Cli::command().get_matches_from(&argv);
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    let sub = matches.subcommand().map(|(_, m)| m);
    let result = match cli.command {
        Command::Render(args) => {
            prepare(&args.scene, &argv, sub, true).and_then(|(scene, settings, cli)| {
                let args = match cli.map(|c| c.command) {
                    Some(Command::Render(a)) => a,
                    _ => args,
                };
                cmd_render(args, scene, &settings)
            })
        }
        Command::Info(args) => {
            prepare(&args.scene, &argv, sub, false).and_then(|(scene, _, _)| cmd_info(args, scene))
        }
        Command::Animate(args) => {
            prepare(&args.scene, &argv, sub, true).and_then(|(scene, settings, cli)| {
                let args = match cli.map(|c| c.command) {
                    Some(Command::Animate(a)) => a,
                    _ => args,
                };
                cmd_animate(args, scene, &settings)
            })
        }
        Command::Bench(args) => bench::cmd_bench(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn progress_for(quiet: bool) -> Box<dyn Progress> {
    if quiet {
        Box::new(shrad::NoProgress)
    } else {
        Box::new(progress::Bars::default())
    }
}

/// Load the scene and take its `[settings.solver]`: every key is checked; when the command
/// has solver options (`solver_options`), those the command line did not give are applied by
/// parsing the command line again with them (returned as the new `Cli`).
fn prepare(
    args: &SceneArgs,
    argv: &[OsString],
    matches: Option<&ArgMatches>,
    solver_options: bool,
) -> Result<(Scene, settings::FileSettings, Option<Cli>)> {
    let scene = load_scene(args)?;
    let matches = matches.filter(|_| solver_options);
    let file = settings::from_file(&scene.source, &scene.settings.solver, matches)?;
    let cli = if solver_options && !file.applied.is_empty() {
        Some(settings::reparse(argv, &file)?)
    } else {
        None
    };
    Ok((scene, file, cli))
}

/// Load the scene and print its warnings.
fn load_scene(args: &SceneArgs) -> Result<Scene> {
    let scene = shrad_scene::load(
        Path::new(&args.scene),
        &LoadOptions {
            drop_degenerate: args.drop_degenerate,
            animation: args.animation.clone(),
        },
    )?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

fn check_range(name: &str, value: usize, lo: usize, hi: usize) -> Result<()> {
    if !(lo..=hi).contains(&value) {
        bail!("{name} must be between {lo} and {hi}, got {value}");
    }
    Ok(())
}

fn check_positive(name: &str, value: f32) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        bail!("{name} must be a positive number, got {value}");
    }
    Ok(())
}

fn sizing(args: &SceneArgs, scene: &Scene) -> Result<PatchSizing> {
    if let Some(h) = args.patch_size {
        check_positive("--patch-size", h)?;
        return Ok(PatchSizing::Size(h));
    }
    if let Some(n) = args.patches {
        if n == 0 || n > 50_000_000 {
            bail!("--patches must be between 1 and 50000000, got {n}");
        }
        return Ok(PatchSizing::Count(n));
    }
    Ok(match (scene.settings.patch_size, scene.settings.patches) {
        (Some(h), _) => PatchSizing::Size(h),
        (None, Some(n)) => PatchSizing::Count(n),
        (None, None) => PatchSizing::Count(20_000),
    })
}

fn backend(b: BackendArg) -> shrad::vis::Backend {
    match b {
        BackendArg::Auto => shrad::vis::Backend::Auto,
        BackendArg::Embree => shrad::vis::Backend::Embree,
        BackendArg::Bvh => shrad::vis::Backend::Bvh,
    }
}

fn build_world(scene: Scene, args: &SceneArgs, quiet: bool) -> Result<World> {
    let sizing = sizing(args, &scene)?;
    let t = Instant::now();
    let world = World::new(scene, sizing, backend(args.backend))?;
    if !quiet {
        let (b, i, l) = world.patches.count_by_role();
        eprintln!(
            "{}: {} patches (boundary {b}, interior {i}, light {l}), patch size {:.4} ({:.2} s)",
            world.scene.source,
            world.patches.len(),
            world.patches.patch_size,
            t.elapsed().as_secs_f64()
        );
        eprintln!(
            "visibility: {}",
            describe_backend(world.vis.name(), args.backend)
        );
    }
    Ok(world)
}

/// The visibility backend in use, for the user: `name` is [`shrad::vis::Visibility::name`].
fn describe_backend(name: &str, requested: BackendArg) -> String {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(threads);
    let compiled = shrad::vis::available_backends().contains(&shrad::vis::Backend::Embree);
    match (name, requested) {
        ("embree", _) => format!("Embree 3 ({threads} threads)"),
        (_, BackendArg::Bvh) => format!("pure-Rust BVH (obvhs, {threads} threads; --backend bvh)"),
        _ if compiled => format!(
            "pure-Rust BVH (obvhs, {threads} threads): Embree is in this build but did not start"
        ),
        _ => format!(
            "pure-Rust BVH (obvhs, {threads} threads) - install libembree-dev (scripts/setup) and rebuild for 2-4x speed"
        ),
    }
}

fn default_output(scene: &str) -> PathBuf {
    let stem = Path::new(scene)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "shrad".into());
    PathBuf::from(format!("{stem}.png"))
}

fn cmd_render(args: RenderArgs, scene: Scene, file: &settings::FileSettings) -> Result<()> {
    if args.width == 0 || args.height == 0 || args.width > 16384 || args.height > 16384 {
        bail!(
            "--width and --height must be between 1 and 16384, got {}x{}",
            args.width,
            args.height
        );
    }
    if args.spp == 0 || args.spp > 4096 {
        bail!("--spp must be between 1 and 4096, got {}", args.spp);
    }
    if let Some(e) = args.exposure {
        check_positive("--exposure", e)?;
    }
    shrad::limits::check_image(args.width, args.height, args.spp)
        .context("--width, --height, --spp")?;
    if !args.time.is_finite() {
        bail!(
            "--time must be a finite number of seconds, got {}",
            args.time
        );
    }
    let choice = args.solver.choice().map_err(|e| file.attribute(e))?;
    let quiet = args.scene.quiet;
    let progress = progress_for(quiet);
    let mut world = build_world(scene, &args.scene, quiet)?;
    if args.time != 0.0 {
        // Before any solver exists: each converges at this pose.
        let (moved, relit) = world.set_time(args.time);
        if !quiet {
            eprintln!(
                "time {} s: {} object(s) moved, {} light(s) changed",
                args.time,
                moved.len(),
                relit.len()
            );
        }
    }
    let t = Instant::now();
    let radiosity = match choice {
        SolverChoice::Reference(options) => {
            let (b, stats) = shrad::reference::solve(&world, &options, progress.as_ref());
            if !quiet {
                eprintln!(
                    "reference: {} iterations, residual {:.2e}{}, direct {:.2} s, form factors {:.2} s ({} entries, {:.1} MiB), solve {:.2} s",
                    stats.iterations,
                    stats.residual,
                    if stats.converged { "" } else { " (NOT converged)" },
                    stats.direct_seconds,
                    stats.form_factor_seconds,
                    stats.form_factor_entries,
                    stats.form_factor_bytes as f64 / (1 << 20) as f64,
                    stats.solve_seconds
                );
                print_energy(&stats.energy);
            }
            if stats.non_finite > 0 {
                eprintln!(
                    "warning: reference: {} non-finite value(s) reset to 0",
                    stats.non_finite
                );
            }
            b
        }
        _ => {
            let mut engine = shrad::engine::Engine::from_world(world, choice);
            let frames = args.frames.unwrap_or_else(|| engine.frames_to_converge(8));
            progress.begin("frames", frames as u64);
            let mut last = None;
            let mut diverged = Vec::new();
            for f in 0..frames {
                let stats = engine.step();
                if let Some(d) = &stats.diverged {
                    diverged.push((f, d.message.clone()));
                }
                last = Some(stats);
                progress.advance(1);
            }
            progress.end();
            if let Some((f, message)) = diverged.first() {
                // Always said, even with --quiet: the published state was repaired.
                eprintln!(
                    "warning: the solver diverged in {} of {frames} frames (first in frame {f}: {message})",
                    diverged.len()
                );
            }
            if let (false, Some(s)) = (quiet, last) {
                eprintln!(
                    "{frames} frames; last frame {:.2} ms (direct {:.2}, objects/probes {:.2}, to boundary {:.2}, assemble {:.2}), invalid probes {}, repaired {}",
                    s.frame_ms, s.direct_ms, s.objects_ms, s.to_boundary_ms, s.assemble_ms, s.probes_invalid, s.probes_repaired
                );
                print_energy(&s.energy);
            }
            let radiosity = engine.radiosity().to_vec();
            world = engine.into_world();
            radiosity
        }
    };
    if args.compare && args.solver.solver != SolverArg::Reference {
        let options = args.solver.reference().map_err(|e| file.attribute(e))?;
        let (reference, _) = shrad::reference::solve(&world, &options, progress.as_ref());
        let e = shrad::metrics::relative_error(&world.patches, &radiosity, &reference);
        println!(
            "error vs reference (spec 8): overall {:.2} %, boundary {:.2} %, interior {:.2} %",
            100.0 * e.overall,
            100.0 * e.boundary,
            100.0 * e.interior
        );
    }
    let solve_seconds = t.elapsed().as_secs_f64();
    let camera = world.scene.camera_or_default();
    let options = RenderOptions {
        width: args.width,
        height: args.height,
        spp: args.spp,
        shading: match args.shading {
            ShadingArg::Smooth => Shading::Smooth,
            ShadingArg::Flat => Shading::Flat,
        },
    };
    let image = render(&world, &radiosity, &camera, &options);
    let tonemap = match args.tonemap {
        TonemapArg::Exposure => Tonemap::Exposure(args.exposure),
        TonemapArg::Minmax => Tonemap::MinMax,
    };
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.scene.scene));
    write_png(&image, &output, tonemap)?;
    if !quiet {
        if let Tonemap::Exposure(scale) = tonemap {
            let scale = scale.unwrap_or_else(|| shrad::image_io::auto_exposure(&image));
            eprintln!("exposure {scale:.6e}");
        }
    }
    if let Some(hdr) = &args.hdr {
        write_exr(&image, hdr)?;
    }
    if let Some(csv) = &args.export_patches {
        shrad::image_io::write_atomic(csv, |tmp| {
            export_patches(&world, &radiosity, tmp).map_err(|e| format!("{e:#}"))
        })?;
    }
    if !quiet {
        eprintln!("solved in {solve_seconds:.2} s; wrote {}", output.display());
    }
    Ok(())
}

fn export_patches(world: &World, radiosity: &[glam::Vec3], path: &Path) -> Result<()> {
    use std::io::Write;
    let file = std::fs::File::create(path).with_context(|| format!("{}", path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    writeln!(w, "object,role,cx,cy,cz,nx,ny,nz,area,r,g,b")?;
    let p = &world.patches;
    for i in 0..p.len() {
        let o = p.object[i] as usize;
        let (c, n, b) = (p.centre[i], p.normal[i], radiosity[i]);
        let name = &world.scene.objects[o].name;
        let name = if name.contains([',', '"', '\n']) {
            format!("\"{}\"", name.replace('"', "\"\""))
        } else {
            name.clone()
        };
        writeln!(
            w,
            "{name},{},{},{},{},{},{},{},{},{},{},{}",
            p.role(i),
            c.x,
            c.y,
            c.z,
            n.x,
            n.y,
            n.z,
            p.area[i],
            b.x,
            b.y,
            b.z
        )?;
    }
    w.flush()?;
    Ok(())
}

fn cmd_info(args: InfoArgs, scene: Scene) -> Result<()> {
    let sizing = sizing(&args.scene, &scene)?;
    println!("scene: {}", scene.source);
    if let Some((lo, hi)) = scene.bounds() {
        println!(
            "bounds: [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
            lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
        );
    }
    match &scene.camera {
        Some(c) => println!(
            "camera: from the scene, yfov {:.2} deg",
            c.yfov.to_degrees()
        ),
        None => println!("camera: none in the scene (a default frames the scene)"),
    }
    if scene.duration() > 0.0 {
        println!("animation: {:.2} s", scene.duration());
    }
    if !scene.animations.is_empty() {
        let playing = scene.animations.iter().filter(|a| a.playing).count();
        println!(
            "glTF animations: {} ({playing} playing; --animation NAME|INDEX plays one)",
            scene.animations.len()
        );
        for a in &scene.animations {
            println!(
                "  {:<3} {:<24} {:>3} channel(s){} {:.3} .. {:.3} s{}",
                a.index,
                a.name,
                a.channels,
                if a.ignored > 0 {
                    format!(" (+{} ignored)", a.ignored)
                } else {
                    String::new()
                },
                a.start,
                a.end,
                if a.playing { "" } else { "  (not playing)" }
            );
        }
    }
    // The same memory check as a solve: a tiny --patch-size is an error, not an abort.
    let plan = shrad::Patches::plan(&scene, sizing);
    shrad::limits::check_patches(&scene.source, plan)?;
    let patches = shrad::Patches::build(&scene, PatchSizing::Size(plan.patch_size));
    println!(
        "patch size: {:.4}, patches: {}",
        patches.patch_size,
        patches.len()
    );
    println!(
        "{:<4} {:<24} {:<9} {:>9} {:>9} {:<22} {:<22} animated",
        "#", "object", "role", "triangles", "patches", "reflectance", "emission L_e"
    );
    for (o, object) in scene.objects.iter().enumerate() {
        let r = object.material.reflectance;
        let e = object.material.emitted_radiance;
        println!(
            "{:<4} {:<24} {:<9} {:>9} {:>9} {:<22} {:<22} {}",
            o,
            object.name,
            object.role(),
            object.mesh.triangles.len(),
            patches.range(o).len(),
            format!("{:.3} {:.3} {:.3}", r.x, r.y, r.z),
            format!("{:.3} {:.3} {:.3}", e.x, e.y, e.z),
            if object.is_animated() { "yes" } else { "no" }
        );
    }
    Ok(())
}

fn cmd_animate(args: AnimateArgs, scene: Scene, file: &settings::FileSettings) -> Result<()> {
    use std::fmt::Write as _;
    check_positive("--fps", args.fps)?;
    // The whole animation by default: frame f shows f / fps, the last one its end.
    let frames = args.frames.unwrap_or_else(|| {
        let d = scene.duration();
        if d > 0.0 {
            ((f64::from(d) * f64::from(args.fps) - 1e-3).ceil() as usize + 1).min(100_000)
        } else {
            120
        }
    });
    if frames == 0 || frames > 100_000 {
        bail!("--frames must be between 1 and 100000, got {frames}");
    }
    if args.width == 0
        || args.height == 0
        || args.width > 8192
        || args.height > 8192
        || args.spp == 0
    {
        bail!("--width, --height must be 1..8192 and --spp at least 1");
    }
    if let Some(e) = args.exposure {
        check_positive("--exposure", e)?;
    }
    shrad::limits::check_image(args.width, args.height, args.spp)
        .context("--width, --height, --spp")?;
    // Every frame is kept (linear, then 8-bit for the GIF) until the exposure is known.
    let stored = (frames as u64)
        .saturating_mul(args.width as u64 * args.height as u64)
        .saturating_mul(12 + 3);
    if stored > shrad::limits::available_bytes() {
        bail!(
            "--frames {} of {}x{} would need {:.1} GiB to keep ({:.1} GiB available); use fewer --frames or a smaller picture",
            frames,
            args.width,
            args.height,
            stored as f64 / (1u64 << 30) as f64,
            shrad::limits::available_bytes() as f64 / (1u64 << 30) as f64
        );
    }
    let choice = args.solver.choice().map_err(|e| file.attribute(e))?;
    let reference_options = args.solver.reference().map_err(|e| file.attribute(e))?;
    let quiet = args.scene.quiet;
    let progress = progress_for(quiet);
    let world = build_world(scene, &args.scene, quiet)?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("{}: cannot create directory", args.output.display()))?;
    let camera = world.scene.camera_or_default();
    let options = RenderOptions {
        width: args.width,
        height: args.height,
        spp: args.spp,
        shading: Shading::Smooth,
    };
    // The engine plays the animation: it poses the scene at each frame's time and tells the
    // solver what moved.
    let names: Vec<String> = world.scene.objects.iter().map(|o| o.name.clone()).collect();
    let mut engine = shrad::engine::Engine::from_world(world, choice);
    engine.set_reference_options(reference_options);
    let warmup = args.warmup * engine.frames_to_converge(1);
    for _ in 0..warmup {
        let _ = engine.step();
    }
    let mut csv = String::from(
        "frame,objects_updated,direct_ms,objects_ms,to_boundary_ms,assemble_ms,frame_ms,error\n",
    );
    let mut extra = String::from("frame,time,stalest,probes_invalid,probes_repaired,emitted,received,absorbed,reflected,object_emitters,error_boundary,error_interior\n");
    let mut images = Vec::with_capacity(frames);
    progress.begin("animating", frames as u64);
    let started = Instant::now();
    for f in 0..frames {
        let time = f as f32 / args.fps;
        engine.set_time(time)?;
        let stats = engine.step();
        if let Some(d) = &stats.diverged {
            eprintln!("warning: frame {f}: the solver diverged: {}", d.message);
        }
        let error = (args.error_every > 0 && f % args.error_every == 0).then(|| engine.error());
        let updated: Vec<&str> = stats
            .objects_updated
            .iter()
            .map(|&o| names[o].as_str())
            .collect();
        let fmt_err = |e: Option<f64>| {
            e.filter(|x| x.is_finite())
                .map_or(String::new(), |x| format!("{x:.6}"))
        };
        let _ = writeln!(
            csv,
            "{f},{},{:.3},{:.3},{:.3},{:.3},{:.3},{}",
            updated.join("|"),
            stats.direct_ms,
            stats.objects_ms,
            stats.to_boundary_ms,
            stats.assemble_ms,
            stats.frame_ms,
            fmt_err(error.map(|e| e.overall))
        );
        let en = stats.energy;
        let _ = writeln!(
            extra,
            "{f},{time:.4},{},{},{},{:.6e},{:.6e},{:.6e},{:.6e},{:.6e},{},{}",
            stats.stalest,
            stats.probes_invalid,
            stats.probes_repaired,
            en.emitted,
            en.received,
            en.absorbed,
            en.reflected,
            en.object_emitters,
            fmt_err(error.map(|e| e.boundary)),
            fmt_err(error.map(|e| e.interior))
        );
        images.push(engine.render(Some(&camera), &options)?);
        progress.advance(1);
    }
    progress.end();
    let solve_seconds = started.elapsed().as_secs_f64();
    // One exposure for every frame, so brightness changes are the light's, not the camera's.
    let scale = args
        .exposure
        .unwrap_or_else(|| shrad::image_io::auto_exposure(&images[images.len() / 2]));
    let mut gif_frames = Vec::with_capacity(images.len());
    for (f, image) in images.iter().enumerate() {
        write_png(
            image,
            &args.output.join(format!("frame_{f:04}.png")),
            Tonemap::Exposure(Some(scale)),
        )?;
        if args.hdr {
            write_exr(image, &args.output.join(format!("frame_{f:04}.exr")))?;
        }
        gif_frames.push(shrad::image_io::to_rgb8(
            image,
            Tonemap::Exposure(Some(scale)),
        ));
    }
    shrad::image_io::write_gif(
        &gif_frames,
        args.width,
        args.height,
        args.fps,
        &args.output.join("animation.gif"),
    )?;
    shrad::image_io::write_atomic(&args.output.join("stats.csv"), |tmp| {
        std::fs::write(tmp, &csv).map_err(|e| e.to_string())
    })?;
    shrad::image_io::write_atomic(&args.output.join("stats_extra.csv"), |tmp| {
        std::fs::write(tmp, &extra).map_err(|e| e.to_string())
    })?;
    let mp4 = args.output.join("animation.mp4");
    // MP4 through ffmpeg when it is installed, written aside and renamed like every output.
    let frames_pattern = args.output.join("frame_%04d.png");
    let ffmpeg = shrad::image_io::write_atomic(&mp4, |tmp| {
        let status = std::process::Command::new("ffmpeg")
            .args(["-nostdin", "-loglevel", "error", "-y", "-framerate"])
            .arg(format!("{}", args.fps))
            .arg("-i")
            .arg(&frames_pattern)
            .args([
                "-pix_fmt",
                "yuv420p",
                "-vf",
                "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            ])
            .arg(tmp)
            // ffmpeg reads commands from stdin: it would eat the input of a calling script.
            .stdin(std::process::Stdio::null())
            .status()
            .map_err(|e| e.to_string())?;
        if status.success() {
            Ok(())
        } else {
            Err(format!("ffmpeg failed ({status})"))
        }
    });
    if !quiet {
        match ffmpeg {
            Ok(()) => eprintln!("wrote {}", mp4.display()),
            Err(e) => {
                eprintln!("no MP4 ({e}; is ffmpeg installed?): the GIF and PNG frames are there")
            }
        }
        eprintln!(
            "wrote {frames} frames ({:.3} s of scene time, {:.1} ms per frame solved and drawn), animation.gif{} and stats.csv to {}",
            (frames - 1) as f32 / args.fps,
            1e3 * solve_seconds / frames as f64,
            if args.hdr { ", frame_NNNN.exr" } else { "" },
            args.output.display()
        );
    }
    Ok(())
}

/// The energy meter's line (spec 2): what the lights emit, what all patches absorb (lights
/// included), and the reflected flux against the most a steady state can reflect.
fn print_energy(e: &shrad::energy::EnergyBalance) {
    eprintln!(
        "energy: emitted {:.4e}, absorbed {:.4e} ({:.1} % of emitted; 100 % in a closed scene at rest), reflected {:.4e} ({:.0} % of the bound {:.4e})",
        e.emitted,
        e.absorbed,
        100.0 * e.closure(),
        e.reflected,
        100.0 * e.bound_ratio(),
        e.reflected_bound
    );
}
