//! `shrad render`: solve a scene at one time on an engine (any solver, the reference
//! included) and write a picture, optionally linear EXR and every patch as CSV.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use shrad::engine::Engine;
use shrad::frame::SolverStats;
use shrad::image_io::Tonemap;
use shrad::render::{RenderOptions, Shading};
use shrad::solver::SolverChoice;
use shrad::{NoProgress, Progress, World};
use shrad_scene::Scene;

use crate::common::{
    build_world, check_positive, check_writable, print_energy, progress_for,
    refuse_overwriting_scene, SceneArgs,
};
use crate::settings::FileSettings;
use crate::solver_args::SolverArgs;

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

/// Options of `shrad render`.
#[derive(Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Dispersive / grid: frames to run on the (static) scene before drawing
    /// [default: 8 passes over the interior objects; for the grid 8 frames and then frames
    /// until its light settles].
    #[arg(long)]
    frames: Option<usize>,
    /// Also solve the reference and print the error of spec section 8 (dispersive / grid).
    #[arg(long)]
    compare: bool,
    /// Scene time in seconds: animated objects and lights are posed at this time, and every
    /// solver solves that pose.
    #[arg(value_parser = crate::common::parse_f32, long, default_value_t = 0.0, allow_negative_numbers = true)]
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
    #[arg(value_parser = crate::common::parse_f32, long, allow_negative_numbers = true)]
    exposure: Option<f32>,
}

fn default_output(scene: &str) -> PathBuf {
    let stem = Path::new(scene)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "shrad".into());
    PathBuf::from(format!("{stem}.png"))
}

/// Check the picture options before anything is solved.
fn check_picture(args: &RenderArgs) -> Result<()> {
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
    let max = shrad::limits::MAX_FRAMES;
    if let Some(frames) = args.frames.filter(|f| !(1..=max).contains(f)) {
        bail!("--frames must be between 1 and {max}, got {frames}");
    }
    check_outputs(args)
}

/// The outputs, before anything is solved (a picture written and a second output refused
/// afterwards left half the set): each in a folder that exists, no two at one path; a
/// warning when a file's extension is not its format's.
fn check_outputs(args: &RenderArgs) -> Result<()> {
    let png = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.scene.scene));
    let outputs = [
        ("-o", Some(png), "png"),
        ("--hdr", args.hdr.clone(), "exr"),
        ("--export-patches", args.export_patches.clone(), "csv"),
    ];
    let given: Vec<(&str, PathBuf, &str)> = outputs
        .into_iter()
        .filter_map(|(flag, path, ext)| Some((flag, path?, ext)))
        .collect();
    for (k, (flag, path, ext)) in given.iter().enumerate() {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            if !dir.is_dir() {
                bail!(
                    "{flag} {}: the folder {} does not exist",
                    path.display(),
                    dir.display()
                );
            }
        }
        if path.is_dir() {
            bail!("{flag} {}: that is a folder, not a file", path.display());
        }
        refuse_overwriting_scene(flag, path, &args.scene.scene)?;
        check_writable(flag, path)?;
        if let Some((other, _, _)) = given[..k]
            .iter()
            .find(|(_, p, _)| shrad::scene::same_file(p, path))
        {
            bail!("{flag} {} is also {other}'s output", path.display());
        }
        let has = path.extension().map(|e| e.to_string_lossy().to_lowercase());
        if has.as_deref() != Some(*ext) && !args.scene.quiet {
            eprintln!(
                "warning: {flag} {}: written as {} whatever its extension",
                path.display(),
                ext.to_uppercase()
            );
        }
    }
    Ok(())
}

/// Run the frames of a solve on `engine` and report them unless `quiet` (also `bake`'s).
pub(crate) fn solve(engine: &mut Engine, frames: Option<usize>, quiet: bool) {
    let reference = matches!(engine.solver_choice(), SolverChoice::Reference(_));
    // Without --frames the grid, one bounce a frame, goes on until its light settles
    // (`Engine::settle_by`): at 8 frames a room of reflectance 0.9 had 61 % of its
    // indirect light.
    let settle = frames.is_none() && matches!(engine.solver_choice(), SolverChoice::Grid(_));
    let frames = frames
        .filter(|_| !reference)
        .unwrap_or_else(|| engine.frames_to_converge(8));
    // A reference frame (one, minutes long) draws its own steps' bars (form factors,
    // iterations); the others' frames (milliseconds each) are counted on one bar.
    let bars = progress_for(quiet);
    let (frame_bar, step_bar): (&dyn Progress, &dyn Progress) = if reference {
        (&NoProgress, bars.as_ref())
    } else {
        (bars.as_ref(), &NoProgress)
    };
    frame_bar.begin("frames", frames as u64);
    let mut last = None;
    let mut diverged = Vec::new();
    let mut stepped = 0usize;
    let mut frame = |engine: &mut Engine| {
        let stats = engine.step_with_progress(step_bar);
        if let Some(d) = &stats.diverged {
            diverged.push((stepped, d.message.clone()));
        }
        stepped += 1;
        last = Some(stats.clone());
        frame_bar.advance(1);
        Ok::<_, std::convert::Infallible>(stats)
    };
    for _ in 0..frames {
        let Ok(_) = frame(engine);
    }
    let frames = frames
        + if settle {
            engine.settle_by(&mut frame).map_or(0, |s| s.len())
        } else {
            0
        };
    frame_bar.end();
    if let Some((f, message)) = diverged.first() {
        // Always said, even with --quiet: the published state was repaired.
        eprintln!(
            "warning: the solver diverged in {} of {frames} frames (first in frame {f}: {message})",
            diverged.len()
        );
    }
    if let Some(r) = last.as_ref().and_then(|s| s.reference()) {
        if r.non_finite > 0 {
            eprintln!(
                "warning: reference: {} non-finite value(s) reset to 0",
                r.non_finite
            );
        }
    }
    if let (false, Some(s)) = (quiet, last) {
        match &s.solver {
            SolverStats::Reference(r) => eprintln!(
                "reference: {} iterations, residual {:.2e}{}, direct {:.2} s, form factors {:.2} s ({} entries, {:.1} MiB), solve {:.2} s",
                r.iterations,
                r.residual,
                if r.converged { "" } else { " (NOT converged)" },
                r.direct_seconds,
                r.form_factor_seconds,
                r.form_factor_entries,
                r.form_factor_bytes as f64 / (1 << 20) as f64,
                r.solve_seconds
            ),
            SolverStats::Dispersive(d) => eprintln!(
                "{frames} frames; last frame {:.2} ms (direct {:.2}, objects/probes {:.2}, to boundary {:.2}, assemble {:.2}), invalid probes {}, repaired {}",
                s.frame_ms, d.direct_ms, d.objects_ms, d.to_boundary_ms, d.assemble_ms, d.probes_invalid, d.probes_repaired
            ),
            SolverStats::Grid(g) => eprintln!(
                "{frames} frames; last frame {:.2} ms (capture {:.2}, shading {:.2}), {} probes, {} invalid",
                s.frame_ms, g.capture_ms, g.shade_ms, g.probes, g.probes_invalid
            ),
        }
        let escaped = shrad::energy::escaped(engine.world(), engine.radiosity(), 16);
        print_energy(&s.energy, Some(escaped));
    }
}

/// Solve, then draw and write.
pub fn run(args: RenderArgs, scene: Scene, file: &FileSettings) -> Result<()> {
    check_picture(&args)?;
    let quiet = args.scene.quiet;
    let choice = args.solver.choice(file, quiet)?;
    let reference = args.solver.reference()?;
    let mut world = build_world(scene, &args.scene, quiet)?;
    if args.time != 0.0 {
        // Before any solver exists: each converges at this pose.
        let (moved, relit) = world.set_time(args.time)?;
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
    let mut engine = Engine::from_world_with_progress(world, choice, &*progress_for(quiet))?;
    engine.set_reference_options(reference);
    solve(&mut engine, args.frames, quiet);
    if args.compare && !matches!(choice, SolverChoice::Reference(_)) {
        let e = engine.error();
        let parts = [e.overall, e.boundary, e.interior];
        let why = match parts.iter().all(|e| e.is_finite()) {
            true => "",
            false => " (-: no patch of that part, or a black reference there)",
        };
        say!(
            "error vs reference (spec 8): overall {}, boundary {}, interior {}{why}",
            percent(e.overall),
            percent(e.boundary),
            percent(e.interior)
        );
    }
    let solve_seconds = t.elapsed().as_secs_f64();
    let options = RenderOptions {
        width: args.width,
        height: args.height,
        spp: args.spp,
        shading: match args.shading {
            ShadingArg::Smooth => Shading::Smooth,
            ShadingArg::Flat => Shading::Flat,
        },
    };
    let image = engine.render(None, &options)?;
    let tonemap = match args.tonemap {
        TonemapArg::Exposure => Tonemap::Exposure(args.exposure),
        TonemapArg::Minmax => Tonemap::MinMax,
    };
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.scene.scene));
    write_outputs(&args, &engine, &image, tonemap, &output)?;
    if !quiet {
        if let Tonemap::Exposure(scale) = tonemap {
            let scale = scale.unwrap_or_else(|| shrad::image_io::auto_exposure(&image));
            eprintln!("exposure {scale:.6e}");
        }
    }
    if !quiet {
        eprintln!("solved in {solve_seconds:.2} s; wrote {}", output.display());
    }
    Ok(())
}

/// The picture, and the EXR and the patches' CSV when asked for, all or nothing: each is
/// staged whole beside its destination and only then renamed into place (a picture written
/// and the EXR refused afterwards replaced the old picture and failed).
fn write_outputs(
    args: &RenderArgs,
    engine: &Engine,
    image: &shrad::render::Image,
    tonemap: Tonemap,
    output: &Path,
) -> Result<()> {
    if let Some(why) = shrad::image_io::png_problem(image) {
        bail!("{}: {why}", output.display());
    }
    let mut staged = shrad::scene::StagedFiles::new();
    staged.stage(output, |tmp| shrad::image_io::png_into(image, tonemap, tmp))?;
    if let Some(hdr) = &args.hdr {
        staged.stage(hdr, |tmp| shrad::image_io::exr_into(image, tmp))?;
    }
    if let Some(csv) = &args.export_patches {
        let (world, radiosity) = (engine.world(), engine.radiosity());
        staged.stage(csv, |tmp| {
            export_patches(world, radiosity, tmp).map_err(|e| format!("{e:#}"))
        })?;
    }
    Ok(staged.commit()?)
}

/// Every patch as a CSV row: object, role, centre, normal, area, radiosity.
fn export_patches(world: &World, radiosity: &[glam::Vec3], path: &Path) -> Result<()> {
    let mut w = csv::Writer::from_path(path).with_context(|| format!("{}", path.display()))?;
    w.write_record([
        "object", "role", "cx", "cy", "cz", "nx", "ny", "nz", "area", "r", "g", "b",
    ])?;
    let p = &world.patches;
    for i in 0..p.len() {
        let o = p.object[i] as usize;
        let (c, n, b) = (p.centre[i], p.normal[i], radiosity[i]);
        let numbers = [c.x, c.y, c.z, n.x, n.y, n.z, p.area[i], b.x, b.y, b.z];
        let mut row = vec![world.scene.objects[o].name.clone(), p.role(i).to_string()];
        row.extend(numbers.iter().map(|x| x.to_string()));
        w.write_record(&row)?;
    }
    w.flush()?;
    Ok(())
}

/// A relative error as a percentage, or "-" where there is none (`relative_error`'s NaN: no
/// patch of that part, or a reference that is black there, as in a scene without light).
fn percent(e: f64) -> String {
    match e.is_finite() {
        true => format!("{:.2} %", 100.0 * e),
        false => "-".to_string(),
    }
}
