//! `shrad animate`: play a scene's animation on an engine, frame by frame: a PNG per frame
//! (and EXR with --hdr), a GIF, an MP4 when ffmpeg is installed, and the frame statistics
//! (`stats.csv`: the paper's Table 3 columns and the error; `stats_extra.csv`: the rest).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Args;
use shrad::engine::Engine;
use shrad::frame::FrameStats;
use shrad::frame::SolverStats;
use shrad::image_io::Tonemap;
use shrad::metrics::RelativeError;
use shrad::render::{Image, RenderOptions, Shading};
use shrad_bench::StepMs;
use shrad_scene::{Scene, StagedFiles};

use crate::common::{build_world, check_positive, progress_for, SceneArgs};
use crate::settings::FileSettings;
use crate::solver_args::SolverArgs;

/// Options of `shrad animate`.
#[derive(Args)]
pub struct AnimateArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Number of frames [default: all of the scene's animation (duration x fps + 1), or 120
    /// for a scene that does not move].
    #[arg(long)]
    frames: Option<usize>,
    /// Frames per second of scene time (frame f shows time f / fps).
    #[arg(value_parser = crate::common::parse_f32, long, default_value_t = 30.0, allow_negative_numbers = true)]
    fps: f32,
    /// Output directory (created if missing).
    #[arg(short, long)]
    output: PathBuf,
    /// Fill the error column (spec 8, against the reference solution of that frame's
    /// geometry) every K frames; 0: never.
    #[arg(long, default_value_t = 0)]
    error_every: usize,
    /// Passes over the objects before frame 0 (a converged start); 0: start from dark.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u64).range(0..=1000))]
    warmup: u64,
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
    #[arg(value_parser = crate::common::parse_f32, long, allow_negative_numbers = true)]
    exposure: Option<f32>,
    /// Also write each frame's linear radiance as OpenEXR (DIR/frame_NNNN.exr).
    #[arg(long)]
    hdr: bool,
}

/// The frame count, checked, and the memory it needs to keep every picture.
fn frame_count(args: &AnimateArgs, scene: &Scene) -> Result<usize> {
    check_positive("--fps", args.fps)?;
    // The whole animation by default: frame f shows f / fps, the last one its end.
    let max = shrad::limits::MAX_FRAMES;
    let frames = match args.frames {
        Some(frames) => frames,
        None => {
            let d = f64::from(scene.duration());
            let whole = (d * f64::from(args.fps) - 1e-3).ceil() + 1.0;
            if d > 0.0 && (whole.is_nan() || whole > max as f64) {
                bail!(
                    "{}: its animation lasts {d:.3e} s, {whole:.3e} frames at --fps {:.3e}: more than \
                     {max}; give --frames (or a lower --fps) to play part of it",
                    scene.source,
                    args.fps
                );
            }
            if d > 0.0 {
                whole as usize
            } else {
                120
            }
        }
    };
    if frames == 0 || frames > max {
        bail!("--frames must be between 1 and {max}, got {frames}");
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
    let available = shrad::limits::available_bytes();
    if stored > available {
        let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
        bail!(
            "--frames {} of {}x{} would need {:.1} GiB to keep ({:.1} GiB available); use fewer --frames or a smaller picture",
            frames,
            args.width,
            args.height,
            gib(stored),
            gib(available)
        );
    }
    Ok(frames)
}

/// The two statistics tables, one row a frame, written through the csv crate.
struct Stats {
    main: csv::Writer<Vec<u8>>,
    extra: csv::Writer<Vec<u8>>,
}

impl Stats {
    fn new() -> Result<Stats> {
        let mut main = csv::Writer::from_writer(Vec::new());
        main.write_record([
            "frame",
            "objects_updated",
            "direct_ms",
            "objects_ms",
            "to_boundary_ms",
            "assemble_ms",
            "frame_ms",
            "error",
        ])?;
        let mut extra = csv::Writer::from_writer(Vec::new());
        extra.write_record([
            "frame",
            "time",
            "stalest",
            "probes_invalid",
            "probes_repaired",
            "emitted",
            "received",
            "absorbed",
            "reflected",
            "object_emitters",
            "error_boundary",
            "error_interior",
        ])?;
        Ok(Stats { main, extra })
    }

    fn push(
        &mut self,
        f: usize,
        time: f32,
        updated: &[&str],
        s: &FrameStats,
        error: Option<RelativeError>,
    ) -> Result<()> {
        let err = |e: Option<f64>| {
            e.filter(|x| x.is_finite())
                .map_or(String::new(), |x| format!("{x:.6}"))
        };
        let ms = |x: f64| format!("{x:.3}");
        let steps = StepMs::of(s);
        let (invalid, repaired) = match &s.solver {
            SolverStats::Dispersive(d) => (d.probes_invalid, d.probes_repaired),
            SolverStats::Grid(g) => (g.probes_invalid, 0),
            SolverStats::Reference(_) => (0, 0),
        };
        self.main.write_record([
            f.to_string(),
            updated.join("|"),
            ms(steps.direct),
            ms(steps.objects),
            ms(steps.to_boundary),
            ms(steps.assemble),
            ms(s.frame_ms),
            err(error.map(|e| e.overall)),
        ])?;
        let en = s.energy;
        let sci = |x: f64| format!("{x:.6e}");
        self.extra.write_record([
            f.to_string(),
            format!("{time:.4}"),
            s.stalest.to_string(),
            invalid.to_string(),
            repaired.to_string(),
            sci(en.emitted),
            sci(en.received),
            sci(en.absorbed),
            sci(en.reflected),
            sci(en.object_emitters),
            err(error.map(|e| e.boundary)),
            err(error.map(|e| e.interior)),
        ])?;
        Ok(())
    }

    fn stage(self, dir: &Path, staged: &mut StagedFiles) -> Result<()> {
        for (name, w) in [("stats.csv", self.main), ("stats_extra.csv", self.extra)] {
            let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
            staged.stage_bytes(&dir.join(name), &bytes)?;
        }
        Ok(())
    }
}

/// Play the animation and write the frames and their statistics.
pub fn run(args: AnimateArgs, scene: Scene, file: &FileSettings) -> Result<()> {
    let frames = frame_count(&args, &scene)?;
    let quiet = args.scene.quiet;
    let choice = args.solver.choice(file, quiet)?;
    let reference = args.solver.reference()?;
    let progress = progress_for(quiet);
    let world = build_world(scene, &args.scene, quiet)?;
    // Every frame's pose, before anything is written.
    for f in 0..frames {
        world.check_time(f as f32 / args.fps)?;
    }
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("{}: cannot create directory", args.output.display()))?;
    check_outputs(&args, frames)?;
    let options = RenderOptions {
        width: args.width,
        height: args.height,
        spp: args.spp,
        shading: Shading::Smooth,
    };
    // The engine plays the animation: it poses the scene at each frame's time and tells the
    // solver what moved.
    let names: Vec<String> = world.scene.objects.iter().map(|o| o.name.clone()).collect();
    let mut engine = Engine::from_world_with_progress(world, choice, &*progress_for(quiet))?;
    engine.set_reference_options(reference);
    for _ in 0..args.warmup as usize * engine.frames_to_converge(1) {
        let _ = engine.step();
    }
    let mut stats = Stats::new()?;
    let mut images: Vec<Image> = Vec::with_capacity(frames);
    progress.begin("animating", frames as u64);
    let started = Instant::now();
    for f in 0..frames {
        let time = f as f32 / args.fps;
        engine.set_time(time)?;
        let s = engine.step();
        if let Some(d) = &s.diverged {
            eprintln!("warning: frame {f}: the solver diverged: {}", d.message);
        }
        let error = (args.error_every > 0 && f % args.error_every == 0).then(|| engine.error());
        let updated: Vec<&str> = s
            .objects_updated
            .iter()
            .map(|&o| names[o].as_str())
            .collect();
        stats.push(f, time, &updated, &s, error)?;
        // The scene's camera at this frame's time: it follows an animated glTF node.
        images.push(engine.render(None, &options)?);
        progress.advance(1);
    }
    progress.end();
    let solve_seconds = started.elapsed().as_secs_f64();
    // Every file or none (a frame that could not be written left the frames before it).
    let mut staged = StagedFiles::new();
    stage_frames(&args, &images, &mut staged)?;
    stats.stage(&args.output, &mut staged)?;
    staged.commit()?;
    let mp4 = write_mp4(&args);
    if !quiet {
        match mp4 {
            Ok(path) => eprintln!("wrote {}", path.display()),
            Err(e) => {
                eprintln!("no MP4 ({e}): the GIF and PNG frames are there")
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

/// The names the outputs take in the output folder, but the MP4 (made after them, from the
/// PNGs, and only where ffmpeg is).
fn output_names(args: &AnimateArgs, frames: usize) -> impl Iterator<Item = PathBuf> + '_ {
    let exts: &[&str] = if args.hdr { &["png", "exr"] } else { &["png"] };
    (0..frames)
        .flat_map(move |f| exts.iter().map(move |e| format!("frame_{f:04}.{e}")))
        .chain(["animation.gif", "stats.csv", "stats_extra.csv"].map(String::from))
        .map(|name| args.output.join(name))
}

/// Before anything is solved: no output name is taken by a folder (found only when it was
/// written, after every frame was solved).
fn check_outputs(args: &AnimateArgs, frames: usize) -> Result<()> {
    if let Some(folder) = output_names(args, frames).find(|p| p.is_dir()) {
        bail!(
            "{}: that is a folder, where this animation writes a file",
            folder.display()
        );
    }
    Ok(())
}

/// PNG (and EXR) per frame and the GIF, all at one exposure, so that brightness changes are
/// the light's, not the camera's.
fn stage_frames(args: &AnimateArgs, images: &[Image], staged: &mut StagedFiles) -> Result<()> {
    let scale = args
        .exposure
        .unwrap_or_else(|| shrad::image_io::auto_exposure(&images[images.len() / 2]));
    let tonemap = Tonemap::Exposure(Some(scale));
    let mut gif_frames = Vec::with_capacity(images.len());
    for (f, image) in images.iter().enumerate() {
        let png = args.output.join(format!("frame_{f:04}.png"));
        if let Some(why) = shrad::image_io::png_problem(image) {
            bail!("{}: {why}", png.display());
        }
        staged.stage(&png, |tmp| shrad::image_io::png_into(image, tonemap, tmp))?;
        if args.hdr {
            let exr = args.output.join(format!("frame_{f:04}.exr"));
            staged.stage(&exr, |tmp| shrad::image_io::exr_into(image, tmp))?;
        }
        gif_frames.push(shrad::image_io::to_rgb8(image, tonemap));
    }
    let size = (args.width, args.height);
    staged.stage(&args.output.join("animation.gif"), |tmp| {
        shrad::image_io::gif_into(&gif_frames, size, args.fps, tmp)
    })?;
    Ok(())
}

/// MP4 through ffmpeg when it is installed, written aside and renamed like every output.
fn write_mp4(args: &AnimateArgs) -> Result<PathBuf, String> {
    let mp4 = args.output.join("animation.mp4");
    let frames_pattern = args.output.join("frame_%04d.png");
    shrad::image_io::write_atomic(&mp4, |tmp| {
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
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::NotFound => "ffmpeg is not installed".to_string(),
                _ => format!("ffmpeg did not start: {e}"),
            })?;
        if status.success() {
            Ok(())
        } else {
            Err(format!("ffmpeg failed ({status})"))
        }
    })
    .map(|()| mp4)
    .map_err(|e| e.to_string())
}
