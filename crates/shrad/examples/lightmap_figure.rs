//! The docs' lightmap figure: the Cornell box with a point light (1.6e5 W/sr at
//! (420, 380, 120) mm) beside its area light, solved by the reference; three pictures at
//! pixel centres, one exposure: shrad's own (light per pixel), the lightmap rendered back
//! (texel x albedo, bilinear) and the vertex-colour bake rendered back (the patches' light
//! interpolated from their corners, as COLOR_0 shows it); below each, a 4x zoom of a
//! shadow edge. Prints each bake's 8x8-block relative RMSE against shrad's picture.
//! `cargo run --release --example lightmap_figure -- OUT.png [patches] [lightmap-res]`.
use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::image_io::{auto_exposure, write_png, Tonemap};
use shrad::lightmap::view::{block_rmse, render_back};
use shrad::lightmap::{layout, texel, LightmapOptions};
use shrad::render::{primary_hits, Image, RenderOptions, Shading, SurfaceLight};
use shrad::solver::SolverChoice;
use shrad::PatchSizing;
use shrad_scene::{Light, LightKind};

const SIDE: u32 = 320;
/// The zoomed square: top-left pixel and side.
const CROP: (u32, u32, u32) = (230, 200, 80);

fn vertex_picture(e: &Engine) -> Image {
    let w = e.world();
    let camera = w.scene.camera.unwrap();
    let light = SurfaceLight::new(w, e.radiosity(), &[], Shading::Smooth);
    let (origins, dirs, hits) = primary_hits(w, &camera, SIDE, SIDE, 1);
    let n = hits.len();
    let mut out = Image {
        width: SIDE,
        height: SIDE,
        pixels: vec![Vec3::ZERO; n],
        emitter: vec![false; n],
    };
    for k in 0..n {
        if let Some(i) = w.seen_patch(&hits[k]) {
            let (s, t) = light.params(i, origins[k] + dirs[k] * hits[k].t);
            let (rho, m) = light.albedo_and_emission(i, s, t);
            out.emitter[k] = w.exitance[i].max_element() > 0.0;
            out.pixels[k] = (rho * light.irradiance(i, s, t, None) + m) / std::f32::consts::PI;
        }
    }
    out
}

/// The three pictures side by side, their crops zoomed 4x below.
fn compose(pictures: &[Image]) -> Image {
    let (w, h) = (SIDE * pictures.len() as u32, 2 * SIDE);
    let mut out = Image {
        width: w,
        height: h,
        pixels: vec![Vec3::ZERO; (w * h) as usize],
        emitter: vec![false; (w * h) as usize],
    };
    let (cx, cy, side) = CROP;
    for (p, img) in pictures.iter().enumerate() {
        for y in 0..SIDE {
            for x in 0..SIDE {
                let top = img.pixels[(y * SIDE + x) as usize];
                let zoom =
                    img.pixels[((cy + y * side / SIDE) * SIDE + cx + x * side / SIDE) as usize];
                out.pixels[(y * w + p as u32 * SIDE + x) as usize] = top;
                out.pixels[((SIDE + y) * w + p as u32 * SIDE + x) as usize] = zoom;
            }
        }
        // The crop's outline on the top picture.
        for k in 0..side {
            for (x, y) in [
                (cx + k, cy),
                (cx + k, cy + side - 1),
                (cx, cy + k),
                (cx + side - 1, cy + k),
            ] {
                out.pixels[(y * w + p as u32 * SIDE + x) as usize] = Vec3::new(1e3, 1e3, 0.0);
            }
        }
    }
    out
}

fn main() {
    let mut args = std::env::args().skip(1);
    let out = std::path::PathBuf::from(
        args.next()
            .expect("usage: lightmap_figure OUT.png [patches] [res]"),
    );
    let patches: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1500);
    let res: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(1024);
    let mut scene = shrad::scene::cornell_box();
    scene.lights.push(Light {
        world_from_light: Affine3A::from_translation(Vec3::new(420.0, 380.0, 120.0)),
        ..Light::new("bulb", LightKind::Point, 683.0 * 1.6e5)
    });
    let choice = SolverChoice::preset("reference", "fast").unwrap();
    let mut e = Engine::new(
        scene,
        PatchSizing::Count(patches),
        shrad::vis::Backend::Auto,
        choice,
    )
    .expect("engine");
    e.step();
    let camera = e.world().scene.camera.unwrap();
    let options = RenderOptions {
        width: SIDE,
        height: SIDE,
        spp: 1,
        shading: Shading::Smooth,
    };
    let own = e.render(Some(&camera), &options).expect("render");
    let opts = LightmapOptions {
        resolution: Some(res),
        ..LightmapOptions::default()
    };
    let l = layout(e.world(), &opts).expect("layout");
    let t = texel::bake(e.world(), &shrad::lightmap::output::surface_light(&e), &l);
    let back = render_back(e.world(), &l, &t.irradiance, &camera, SIDE, SIDE);
    let vertex = vertex_picture(&e);
    println!(
        "{} patches, lightmap {res}x{res}, texel {:.2} mm, {} charts",
        e.world().patches.len(),
        l.texel,
        l.charts.len()
    );
    println!(
        "8x8 block relative RMSE against shrad's picture: lightmap {:.2} %, vertex colours {:.2} %",
        100.0 * block_rmse(&own, &back),
        100.0 * block_rmse(&own, &vertex)
    );
    let exposure = auto_exposure(&own);
    write_png(
        &compose(&[own, back, vertex]),
        &out,
        Tonemap::Exposure(Some(exposure)),
    )
    .expect("png");
    println!("wrote {}", out.display());
}
