//! `shrad info`: what a scene contains (objects, roles, materials, patches, animations),
//! without solving anything.

use anyhow::Result;
use clap::Args;
use shrad::PatchSizing;
use shrad_scene::Scene;

use crate::common::{sizing, SceneArgs};
use crate::settings::FileSettings;
use crate::solver_args::SolverArgs;

/// Options of `shrad info`.
#[derive(Args)]
pub struct InfoArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
}

fn print_animations(scene: &Scene) {
    if scene.duration() > 0.0 {
        say!("animation: {:.2} s", scene.duration());
    }
    if scene.animations.is_empty() {
        return;
    }
    let playing = scene.animations.iter().filter(|a| a.playing).count();
    say!(
        "glTF animations: {} ({playing} playing; --animation NAME|INDEX plays one)",
        scene.animations.len()
    );
    for a in &scene.animations {
        say!(
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

/// The punctual lights: kind, intensity in the file's photometric units and in watts (per
/// steradian, or per square metre for a directional light: the 683 lm/W of
/// `docs/scene-format.md`), position or direction.
fn print_lights(scene: &Scene) {
    if scene.lights.is_empty() {
        return;
    }
    say!(
        "{:<4} {:<24} {:<11} {:>14} {:>14}  {:<30} animated",
        "#",
        "light",
        "kind",
        "intensity",
        "radiometric",
        "position / direction"
    );
    for (l, light) in scene.lights.iter().enumerate() {
        use shrad::scene::{Light, LightKind};
        let m = light.world_from_light;
        let (unit, w_unit, place) = match light.kind {
            LightKind::Directional => {
                let d = Light::direction(&m).unwrap_or_default();
                (
                    "lx",
                    "W/m^2",
                    format!("towards {:.3} {:.3} {:.3}", d.x, d.y, d.z),
                )
            }
            LightKind::Point => {
                let p = Light::position(&m);
                ("cd", "W/sr", format!("at {:.3} {:.3} {:.3}", p.x, p.y, p.z))
            }
            LightKind::Spot { .. } => {
                let (p, d) = (
                    Light::position(&m),
                    Light::direction(&m).unwrap_or_default(),
                );
                let place = format!(
                    "at {:.3} {:.3} {:.3} towards {:.3} {:.3} {:.3}",
                    p.x, p.y, p.z, d.x, d.y, d.z
                );
                ("cd", "W/sr", place)
            }
        };
        let cone = match light.kind {
            LightKind::Spot {
                outer_cone_angle, ..
            } if light.cone_falloff == shrad::scene::ConeFalloff::Blender => format!(
                " (cone {:.1} deg, Blender's blend {:.2})",
                outer_cone_angle.to_degrees(),
                light.spot_blend().unwrap_or(0.0)
            ),
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => format!(
                " (cone {:.1}..{:.1} deg)",
                inner_cone_angle.to_degrees(),
                outer_cone_angle.to_degrees()
            ),
            _ => String::new(),
        };
        let w = light.radiometric();
        say!(
            "{:<4} {:<24} {:<11} {:>14} {:>14}  {:<30} {}{cone}",
            l,
            light.name,
            light.kind.name(),
            format!("{:.4} {unit}", light.intensity),
            format!("{:.4} {w_unit}", w.max_element()),
            place,
            if light.is_animated() { "yes" } else { "no" }
        );
    }
}

/// The sky, with `--sky` / `--env` / `--env-rotate` / `--env-scale` applied.
fn print_environment(scene: &Scene) {
    let Some(env) = &scene.environment else {
        return;
    };
    match &env.map {
        Some(map) => say!(
            "sky: map {} ({} x {} texels), rotated {} deg, scale {}",
            map.path.display(),
            map.width,
            map.height,
            env.rotate_deg,
            env.scale
        ),
        None => {
            let r = env.radiance * env.scale;
            say!(
                "sky: uniform, radiance {:.4} {:.4} {:.4} W/(m^2 sr)",
                r.x,
                r.y,
                r.z
            )
        }
    }
}

/// Print the scene. The file's `[settings.solver]` is checked as a solve would apply it,
/// values too (`cube_res = 0` passed here and failed in `render`).
pub fn run(args: InfoArgs, scene: Scene, file: &FileSettings) -> Result<()> {
    let sizing = sizing(&args.scene, &scene)?;
    let solver = SolverArgs::default().choice(file, false)?;
    say!("scene: {}", scene.source);
    if file.solver.is_some() || file.preset.is_some() || !file.keys.is_empty() {
        say!(
            "solver: {} (preset {}), from the file's [settings.solver]",
            solver.name(),
            solver.preset_name().unwrap_or("custom")
        );
    }
    if let Some(shrad::scene::Aabb { min: lo, max: hi }) = scene.bounds() {
        say!(
            "bounds: [{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
            lo.x,
            lo.y,
            lo.z,
            hi.x,
            hi.y,
            hi.z
        );
    }
    match &scene.camera {
        Some(c) => say!(
            "camera: from the scene, yfov {:.2} deg",
            c.yfov.to_degrees()
        ),
        None => say!("camera: none in the scene (a default frames the scene)"),
    }
    print_animations(&scene);
    print_lights(&scene);
    print_environment(&scene);
    // The same memory check as a solve: a tiny --patch-size is an error, not an abort.
    let plan = shrad::Patches::plan(&scene, sizing);
    shrad::limits::check_patches(&scene, plan)?;
    let patches = shrad::Patches::build(&scene, PatchSizing::Size(plan.patch_size));
    say!(
        "patch size: {:.4}, patches: {}",
        patches.patch_size,
        patches.len()
    );
    say!(
        "{:<4} {:<24} {:<9} {:>9} {:>9} {:<22} {:<22} animated",
        "#",
        "object",
        "role",
        "triangles",
        "patches",
        "reflectance",
        "emission L_e"
    );
    for (o, object) in scene.objects.iter().enumerate() {
        let r = object.material.reflectance;
        let e = object.material.emitted_radiance;
        say!(
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
