//! What every command that loads a scene shares: the scene options, loading with warnings,
//! the patch sizing, the world with its one-line summary, the visibility backend's
//! description, progress bars and the energy line.

use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use shrad::{PatchSizing, Progress, World};
use shrad_scene::{LoadOptions, Scene};

/// Options shared by every command that loads a scene.
#[derive(Args, Clone)]
pub struct SceneArgs {
    /// Scene: a .gltf, .glb, .obj or .toml file, or a built-in name (cornell, room).
    pub scene: String,
    /// Patch edge length in scene units [default: the scene file's, else --patches].
    #[arg(value_parser = crate::common::parse_f32, long, conflicts_with = "patches", allow_negative_numbers = true)]
    pub patch_size: Option<f32>,
    /// Target total patch count [default: the scene file's, else 20000].
    #[arg(long)]
    pub patches: Option<usize>,
    /// OBJ and scene files: skip zero-area triangles (with a warning) instead of rejecting
    /// the file (glTF files always drop them, with a warning).
    #[arg(long)]
    pub drop_degenerate: bool,
    /// glTF: play only this animation, by name or index [default: every animation of the
    /// file at once, on one timeline].
    #[arg(long, value_name = "NAME|INDEX")]
    pub animation: Option<String>,
    /// A uniform sky of this linear radiance (W / (m^2 sr)), e.g. 0.5,0.6,0.8 (replaces the
    /// scene file's `[environment]`).
    #[arg(long, value_name = "R,G,B", conflicts_with = "env")]
    pub sky: Option<String>,
    /// A sky from an equirectangular map: linear OpenEXR (.exr) or Radiance (.hdr), top row
    /// +Y (replaces the scene file's `[environment]`).
    #[arg(long, value_name = "FILE")]
    pub env: Option<std::path::PathBuf>,
    /// Turn the sky's map about +Y by this many degrees [default: the scene file's, else 0].
    #[arg(value_parser = crate::common::parse_f32, long, value_name = "DEG", allow_negative_numbers = true)]
    pub env_rotate: Option<f32>,
    /// Scale the sky's radiance [default: the scene file's, else 1].
    #[arg(value_parser = crate::common::parse_f32, long, value_name = "S", allow_negative_numbers = true)]
    pub env_scale: Option<f32>,
    /// Visibility backend.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// No progress bars and no informational lines (errors and warnings still print).
    #[arg(long, short)]
    pub quiet: bool,
}

/// The visibility backend asked for.
#[derive(Clone, Copy, ValueEnum)]
pub enum BackendArg {
    /// Embree when this build has it, else the pure-Rust BVH.
    Auto,
    /// Intel Embree 3.
    Embree,
    /// Pure-Rust BVH.
    Bvh,
}

impl BackendArg {
    /// The library's backend.
    pub fn backend(self) -> shrad::vis::Backend {
        match self {
            BackendArg::Auto => shrad::vis::Backend::Auto,
            BackendArg::Embree => shrad::vis::Backend::Embree,
            BackendArg::Bvh => shrad::vis::Backend::Bvh,
        }
    }
}

/// Progress bars, or nothing with `--quiet`.
pub fn progress_for(quiet: bool) -> Box<dyn Progress> {
    if quiet {
        Box::new(shrad::NoProgress)
    } else {
        Box::new(crate::progress::Bars::default())
    }
}

/// Load the scene and print its warnings.
pub fn load_scene(args: &SceneArgs) -> Result<Scene> {
    let scene = shrad_scene::load(
        Path::new(&args.scene),
        &LoadOptions {
            drop_degenerate: args.drop_degenerate,
            animation: args.animation.clone(),
        },
    )?;
    let mut scene = scene;
    apply_sky(args, &mut scene)?;
    if scene.has_emitter() {
        scene.warnings.retain(|w| !w.contains("has no emitter"));
    }
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// The command line's sky (`--sky`, `--env`, `--env-rotate`, `--env-scale`) on `scene`.
pub fn apply_sky(args: &SceneArgs, scene: &mut Scene) -> Result<()> {
    if let Some(text) = &args.sky {
        let v: Vec<f32> = text
            .split(',')
            .map(|c| c.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| anyhow::anyhow!("--sky {text}: expected three numbers R,G,B"))?;
        let [r, g, b] = v[..] else {
            bail!("--sky {text}: expected three numbers R,G,B");
        };
        scene.environment = Some(shrad_scene::Environment::uniform(glam::Vec3::new(r, g, b)));
    }
    if let Some(path) = &args.env {
        let map = shrad_scene::EnvMap::load(path)?;
        scene.environment = Some(shrad_scene::Environment::from_map(map));
    }
    if args.env_rotate.is_some() || args.env_scale.is_some() {
        let Some(env) = scene.environment.as_mut() else {
            bail!("--env-rotate and --env-scale need a sky (--sky, --env or the scene's [environment])");
        };
        env.rotate_deg = args.env_rotate.unwrap_or(env.rotate_deg);
        env.scale = args.env_scale.unwrap_or(env.scale);
    }
    if let Some(why) = scene.environment.as_ref().and_then(|e| e.problem()) {
        bail!("{why}");
    }
    Ok(())
}

/// A number option read as the 32-bit float the library takes, refused when that float is
/// not the number typed: `--time=-1e300` became -inf and `--exposure 1e-50` 0, and the
/// errors said "got -inf", "got 0". (NaN and infinities typed as such pass, for the checks
/// that name the option.)
pub fn parse_f32(text: &str) -> Result<f32, String> {
    let wide: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    let narrow = wide as f32;
    let lost = wide.is_finite() && (!narrow.is_finite() || (narrow == 0.0) != (wide == 0.0));
    if lost {
        return Err(format!(
            "{text} is beyond what a 32-bit float holds (up to 3.4e38 in size, and no closer \
             to 0 than 1.4e-45)"
        ));
    }
    Ok(narrow)
}

/// `value` must be a finite number above 0; the error names the option.
pub fn check_positive(name: &str, value: f32) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        bail!("{name} must be a positive number, got {value}");
    }
    Ok(())
}

/// The patch sizing: the command line's, else the scene file's, else the library's default.
pub fn sizing(args: &SceneArgs, scene: &Scene) -> Result<PatchSizing> {
    Ok(PatchSizing::choose(
        args.patch_size,
        args.patches,
        &scene.settings,
        ["--patch-size", "--patches"],
    )?)
}

/// Patch the scene and build its visibility, saying what it made unless `quiet`.
pub fn build_world(scene: Scene, args: &SceneArgs, quiet: bool) -> Result<World> {
    let sizing = sizing(args, &scene)?;
    let t = Instant::now();
    let world = World::new(scene, sizing, args.backend.backend())?;
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
pub fn describe_backend(name: &str, requested: BackendArg) -> String {
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

/// The energy meter's line (spec 2): what the lights emit, what all patches absorb (lights
/// included), what leaves through the openings (`escaped`, when measured and not nil), and
/// the reflected flux against the most a steady state can reflect.
pub fn print_energy(e: &shrad::energy::EnergyBalance, escaped: Option<f64>) {
    let open = escaped.filter(|&x| x > 1e-4 * e.emitted);
    let left = match open {
        Some(x) => format!(
            "; left through the openings {x:.4e} ({:.1} %; absorbed + left {:.1} % of emitted, where exact light at rest gives 100 %)",
            100.0 * x / e.emitted.max(f64::MIN_POSITIVE),
            100.0 * (e.absorbed + x) / e.emitted.max(f64::MIN_POSITIVE)
        ),
        None => " (exact light in a closed scene at rest absorbs 100 %)".to_string(),
    };
    eprintln!(
        "energy: emitted {:.4e}, absorbed {:.4e} ({:.1} % of emitted){left}, reflected {:.4e} ({:.0} % of the bound {:.4e})",
        e.emitted,
        e.absorbed,
        100.0 * e.closure(),
        e.reflected,
        100.0 * e.bound_ratio(),
        e.reflected_bound
    );
}

/// Refuse an output whose folder cannot be written (a read-only folder, `/proc`), before
/// the solve: a file is made there and removed. A device or pipe is written into instead.
pub fn check_writable(flag: &str, output: &Path) -> Result<()> {
    if std::fs::metadata(output).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
        return Ok(());
    }
    let dir = output.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or(Path::new("."));
    let probe = dir.join(format!(".shrad-can-write-{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => bail!(
            "{flag} {}: cannot write in {}: {e}",
            output.display(),
            dir.display()
        ),
    }
}

/// Refuse an output that is the scene file being read (`scene` as given: a built-in name
/// is no file): `render x.obj -o x.obj` wrote its PNG over the scene, exit 0.
pub fn refuse_overwriting_scene(flag: &str, output: &Path, scene: &str) -> Result<()> {
    let input = Path::new(scene);
    if input.is_file() && shrad::scene::same_file(output, input) {
        bail!(
            "{flag} {}: that is the scene file being read; write to another name",
            output.display()
        );
    }
    Ok(())
}
