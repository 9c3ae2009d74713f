//! The docs' point-light figure: a box on a floor under a point light (683 cd, 1 W/sr),
//! shrad's dispersive default beside the reference, each picture with its punctual light
//! evaluated per pixel (a shadow ray a pixel) and the indirect light from the patches; the
//! two at one exposure. Prints the 8x8-block relative RMSE of the default against the
//! reference and each one's patch error.
//! `cargo run --release --example point_light_figure -- OUT_DIR [patches]`.
use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::image_io::{auto_exposure, write_png, Tonemap};
use shrad::render::{Image, RenderOptions};
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::PatchSizing;
use shrad_scene::{box_mesh, quad, Camera, Light, LightKind, Material, Object, Role, Scene};

fn scene() -> Scene {
    let a = 2.0;
    let floor = quad([
        Vec3::new(-a, 0.0, -a),
        Vec3::new(-a, 0.0, a),
        Vec3::new(a, 0.0, a),
        Vec3::new(a, 0.0, -a),
    ]);
    Scene {
        source: "point-light figure".into(),
        objects: vec![
            Object {
                role: Some(Role::Boundary),
                ..Object::new("floor", floor, Material::diffuse(Vec3::splat(0.7)))
            },
            Object {
                role: Some(Role::Interior),
                world_from_object: Affine3A::from_translation(Vec3::new(0.0, 0.3, 0.0)),
                ..Object::new(
                    "box",
                    box_mesh(Vec3::splat(0.3), false),
                    Material::diffuse(Vec3::new(0.7, 0.3, 0.2)),
                )
            },
        ],
        lights: vec![Light {
            world_from_light: Affine3A::from_translation(Vec3::new(0.9, 1.6, 0.5)),
            ..Light::new("bulb", LightKind::Point, 683.0)
        }],
        camera: Some(Camera::look_at(
            Vec3::new(-2.2, 2.4, 3.2),
            Vec3::new(-0.2, 0.1, 0.0),
            0.8,
        )),
        ..Default::default()
    }
}

/// Relative RMSE of 8x8-block means of linear radiance (luminance-free: RGB averaged).
fn block_rmse(a: &Image, b: &Image) -> f64 {
    let (w, h) = (a.width as usize, a.height as usize);
    let (mut num, mut den) = (0.0, 0.0);
    for by in 0..h / 8 {
        for bx in 0..w / 8 {
            let mean = |img: &Image| {
                let mut s = 0.0;
                for y in 0..8 {
                    for x in 0..8 {
                        s += img.pixels[(by * 8 + y) * w + bx * 8 + x].element_sum() as f64;
                    }
                }
                s / 192.0
            };
            let (ma, mb) = (mean(a), mean(b));
            num += (ma - mb) * (ma - mb);
            den += mb * mb;
        }
    }
    (num / den.max(1e-30)).sqrt()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let out = std::path::PathBuf::from(
        args.next()
            .expect("usage: point_light_figure OUT_DIR [patches]"),
    );
    let patches: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(4000);
    let options = RenderOptions {
        width: 256,
        height: 256,
        spp: 4,
        ..Default::default()
    };
    let mut pictures = Vec::new();
    for (name, solver, preset) in [
        ("reference", "reference", "standard"),
        ("default", "dispersive", "default"),
    ] {
        let choice = SolverChoice::preset(solver, preset).unwrap();
        let mut e = Engine::new(scene(), PatchSizing::Count(patches), Backend::Auto, choice)
            .expect("engine");
        e.converge(4);
        if name == "default" {
            println!("default: patch error {:.2} %", 100.0 * e.error().overall);
        }
        pictures.push((name, e.render(None, &options).expect("render")));
    }
    let exposure = auto_exposure(&pictures[0].1);
    for (name, image) in &pictures {
        let path = out.join(format!("point_light_{name}.png"));
        write_png(image, &path, Tonemap::Exposure(Some(exposure))).expect("png");
        println!("wrote {}", path.display());
    }
    println!(
        "8x8 block relative RMSE, default vs reference: {:.2} %",
        100.0 * block_rmse(&pictures[1].1, &pictures[0].1)
    );
}
