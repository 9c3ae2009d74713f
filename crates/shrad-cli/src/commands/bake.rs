//! `shrad bake`: solve a scene and write its light per vertex as glTF (`COLOR_0` under an
//! unlit material, the unclamped radiosity in `_RADIOSITY`) for three.js, Blender or Godot;
//! an animation as a sequence of files. The file format is the library's
//! (`shrad::bake`); the engine is made and converged as `render` does.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Result};
use clap::Args;
use shrad::bake::{bake_with_progress, BakeOptions};
use shrad::engine::Engine;
use shrad::lightmap::{LightmapFormat, LightmapOptions};
use shrad_scene::Scene;

use crate::commands::render::solve;
use crate::common::{
    build_world, check_positive, check_writable, progress_for, refuse_overwriting_scene, SceneArgs,
};
use crate::settings::FileSettings;
use crate::solver_args::SolverArgs;

/// Options of `shrad bake`.
#[derive(Args)]
pub struct BakeArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub solver: SolverArgs,
    /// Output: .glb (binary), or .gltf with its buffer in a .bin beside it.
    #[arg(short, long)]
    output: PathBuf,
    /// Scene time in seconds to bake: animated objects and lights are posed at this time.
    #[arg(value_parser = crate::common::parse_f32, long, allow_negative_numbers = true, conflicts_with = "frames")]
    time: Option<f32>,
    /// Bake the animation as N files evenly over [0, duration]: OUT_0000.glb, OUT_0001.glb...
    /// (glTF has no standard per-frame vertex colour; a file per frame shows everywhere).
    /// All or nothing: the files are renamed into place once all are written, so a bake
    /// that fails partway, or is stopped (Ctrl-C), leaves none of them.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=shrad::limits::MAX_FRAMES as u64))]
    frames: Option<u64>,
    /// With --frames: passes over the objects before each file (every object updated this
    /// many times), after the first pose has converged as `render` converges.
    #[arg(
        long,
        requires = "frames",
        default_value_t = BakeOptions::default().passes as u64,
        value_parser = clap::value_parser!(u64).range(0..=1000)
    )]
    passes: u64,
    /// Display scale of COLOR_0 (clamp(exposure * B / pi, 0, 1)) [default: auto, as a PNG's:
    /// the 99th percentile of non-light luminance to 0.9, from the first file for them all].
    #[arg(value_parser = crate::common::parse_f32, long, allow_negative_numbers = true)]
    exposure: Option<f32>,
    /// Also write SH irradiance probes for dynamic objects as JSON beside the output
    /// (OUT.probes.json), in three.js's LightProbe coefficient order. `corners`: the
    /// dispersive solver's 8 probes at each interior object's corners.
    #[arg(long, value_name = "WHERE", value_parser = ["corners"], conflicts_with = "frames")]
    probes: Option<String>,
    /// Write the light into a lightmap: a texture atlas over TEXCOORD_1 (charts: the file's
    /// own TEXCOORD_1 when usable, else the patches' planar faces, grown into near-flat
    /// charts on curved meshes), evaluated per texel as pictures are, as PNGs in the glTF
    /// (the lit surface under an unlit material; the lightmap for three.js's lightMap on
    /// uv1) and beside it as a linear OpenEXR (OUT.lightmap.exr, E / pi) or an RGBM PNG
    /// (--lightmap-format). See docs/results.md section 12.
    #[arg(long)]
    lightmap: bool,
    /// With --lightmap: the texel edge in metres (scene units).
    #[arg(
        long,
        value_name = "M",
        requires = "lightmap",
        conflicts_with = "lightmap_res",
        allow_negative_numbers = true,
        value_parser = crate::common::parse_f32
    )]
    texel_size: Option<f32>,
    /// With --lightmap: the atlas's side in texels [default: 1024]; the texel size is the
    /// smallest at which the charts fit.
    #[arg(long, value_name = "N", requires = "lightmap")]
    lightmap_res: Option<u32>,
    /// With --lightmap: the lightmap file beside the glTF [default: exr]. `exr`:
    /// OUT.lightmap.exr, linear float. `rgbm`: OUT.lightmap.png for 8-bit pipelines, RGBM in
    /// an RGBA PNG: E / pi = rgb * a * multiplier (bytes / 255, linear, not premultiplied),
    /// the multiplier (a power of two, nothing clips) printed and in the glTF's
    /// asset.extras.shrad.lightmap.rgbm.
    #[arg(long, value_name = "FORMAT", requires = "lightmap", value_parser = LightmapFormat::NAMES)]
    lightmap_format: Option<String>,
}

/// What can be checked before patching and solving: the options, the output's name and
/// folder, and that a sequence has an animation to span.
fn check(args: &BakeArgs, scene: &Scene) -> Result<()> {
    if let Some(t) = args.time {
        if !t.is_finite() {
            bail!("--time must be a finite number of seconds, got {t}");
        }
    }
    if let Some(e) = args.exposure {
        check_positive("--exposure", e)?;
    }
    if let Some(m) = args.texel_size {
        check_positive("--texel-size", m)?;
    }
    if let Some(n) = args.lightmap_res {
        let max = shrad::limits::MAX_IMAGE_SIDE;
        if !(8..=max).contains(&n) {
            bail!("--lightmap-res {n}: the atlas's side must be 8 to {max} texels");
        }
    }
    let out = &args.output;
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("glb" | "gltf")) {
        bail!(
            "-o {}: a bake is written as .glb (binary) or .gltf (JSON and a .bin beside it)",
            out.display()
        );
    }
    let folder = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        bail!(
            "-o {}: the folder {} does not exist",
            out.display(),
            folder.display()
        );
    }
    check_writable("-o", out)?;
    // The file, the `.bin` beside a `.gltf`, the lightmap and the probes.
    for written in ["", "bin", "lightmap.exr", "probes.json"] {
        let path = match written {
            "" => out.clone(),
            ext => out.with_extension(ext),
        };
        refuse_overwriting_scene("-o", &path, &args.scene.scene)?;
        // (The probes are written after the rest is in place: a folder at their name
        // failed there and left the rest.)
        if path.is_dir() {
            bail!(
                "-o {}: {} would be written, and is a folder",
                out.display(),
                path.display()
            );
        }
    }
    if let Some(n) = args.frames.filter(|&n| n > 1) {
        if scene.duration() <= 0.0 {
            bail!(
                "--frames {n}: {} is not animated, so its {n} frames would all be the same (bake one file without --frames)",
                scene.source
            );
        }
    }
    Ok(())
}

/// The corner probes as JSON beside `output` (`OUT.probes.json`; format in docs/python.md).
fn write_probes(engine: &Engine, output: &Path, quiet: bool) -> Result<()> {
    let Some(probes) = shrad::probe_export::corner_probes(engine) else {
        bail!(
            "--probes corners: the {} solver has no per-object probes (use the dispersive solver)",
            engine.solver_choice().name()
        );
    };
    if probes.is_empty() {
        eprintln!("warning: --probes corners: the scene has no interior object to probe");
    }
    let path = output.with_extension("probes.json");
    let text = shrad::probe_export::to_json_text(engine, &probes);
    shrad_scene::write_atomic(&path, |tmp| {
        std::fs::write(tmp, &text).map_err(|e| e.to_string())
    })?;
    if !quiet {
        say!("wrote {}: {} probes, 3 bands", path.display(), probes.len());
    }
    Ok(())
}

/// A longer sequence baked at `output`'s names before left its later files: say so, they
/// do not belong to these `n` frames.
fn warn_of_earlier_frames(output: &Path, n: usize) {
    let next = shrad::bake::frame_path(output, n);
    if next.is_file() {
        eprintln!(
            "warning: {} and any after it are from an earlier bake, not of these {n} frames",
            next.display()
        );
    }
}

/// Solve, then write the file or the sequence.
pub fn run(args: BakeArgs, scene: Scene, file: &FileSettings) -> Result<()> {
    check(&args, &scene)?;
    let quiet = args.scene.quiet;
    let choice = args.solver.choice(file, quiet)?;
    // Refused before any solving: only the dispersive solver has per-object probes.
    if args.probes.is_some() && choice.name() != "dispersive" {
        bail!(
            "--probes corners: the {} solver has no per-object probes (add --solver dispersive)",
            choice.name()
        );
    }
    let reference = args.solver.reference()?;
    let mut world = build_world(scene, &args.scene, quiet)?;
    // A sequence starts at 0; one file at --time, posed before any solver exists (as in
    // `render`), so the solver converges at that pose.
    let time = args.time.unwrap_or(0.0);
    if time != 0.0 {
        let (moved, relit) = world.set_time(time)?;
        if !quiet {
            eprintln!(
                "time {time} s: {} object(s) moved, {} light(s) changed",
                moved.len(),
                relit.len()
            );
        }
    }
    let t = Instant::now();
    let mut engine = Engine::from_world(world, choice)?;
    engine.set_reference_options(reference);
    solve(&mut engine, None, quiet);
    let frames = args.frames.map(|n| n as usize);
    if let (Some(n), false) = (frames, quiet) {
        eprintln!(
            "baking {n} file(s) over {:.3} s, {} pass(es) before each",
            engine.world().scene.duration(),
            args.passes
        );
    }
    let options = BakeOptions {
        // The engine is at --time already.
        time: None,
        frames,
        passes: if frames.is_some() {
            args.passes as usize
        } else {
            0
        },
        exposure: args.exposure,
    };
    let progress = progress_for(quiet);
    let baked = if args.lightmap {
        let lightmap = LightmapOptions {
            texel_size: args.texel_size,
            resolution: args.lightmap_res,
            format: LightmapFormat::from_name(args.lightmap_format.as_deref().unwrap_or("exr"))?,
            ..LightmapOptions::default()
        };
        shrad::lightmap::bake_with_progress(
            &mut engine,
            &args.output,
            &options,
            &lightmap,
            &*progress,
        )?
    } else {
        bake_with_progress(&mut engine, &args.output, &options, &*progress)?
    };
    // A sequence repeats the same layout's warnings: each once.
    let mut warned = std::collections::HashSet::new();
    for w in baked.iter().flat_map(|b| &b.warnings) {
        if warned.insert(w) {
            eprintln!("warning: {w}");
        }
    }
    if args.probes.is_some() {
        write_probes(&engine, &args.output, quiet)?;
    }
    if let Some(n) = frames {
        warn_of_earlier_frames(&args.output, n);
    }
    if !quiet {
        for b in &baked {
            say!(
                "wrote {}: time {} s, {} meshes, {} vertices, {} triangles, exposure {:.6e}",
                b.path.display(),
                b.time,
                b.meshes,
                b.vertices,
                b.triangles,
                b.exposure
            );
            if let (Some(f), Some(encoding)) = (&b.lightmap_file, &b.lightmap_encoding) {
                say!("  and its lightmap {} ({encoding})", f.display());
            }
        }
        eprintln!("solved and baked in {:.2} s", t.elapsed().as_secs_f64());
    }
    Ok(())
}
