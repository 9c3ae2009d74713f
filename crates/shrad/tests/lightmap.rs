//! Lightmaps (`shrad::lightmap`): rendered back (texture x albedo at pixel centres) they
//! match shrad's own picture of the same state; with a point light they hold its shadow
//! edge where the vertex-colour bake smears it; the glTF's second UV set has no overlap;
//! bad options are errors.

use std::path::PathBuf;

use glam::{Affine3A, Vec2, Vec3};
use shrad::bake::BakeOptions;
use shrad::engine::Engine;
use shrad::lightmap::view::{block_rmse, render_back};
use shrad::lightmap::{layout, texel, LightmapOptions};
use shrad::render::{Image, RenderOptions, Shading, SurfaceLight};
use shrad::solver::SolverChoice;
use shrad::{NoProgress, PatchSizing};
use shrad_scene::{Light, LightKind, Scene};

/// The Cornell box (mm), with a point light (1.6e5 W/sr) when `bulb`.
fn cornell(bulb: bool) -> Scene {
    let mut s = shrad::scene::cornell_box();
    if bulb {
        s.lights.push(Light {
            world_from_light: Affine3A::from_translation(Vec3::new(420.0, 380.0, 120.0)),
            ..Light::new("bulb", LightKind::Point, 683.0 * 1.6e5)
        });
    }
    s
}

fn engine(scene: Scene, patches: usize) -> Engine {
    let mut e = Engine::new(
        scene,
        PatchSizing::Count(patches),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    e.step();
    e
}

const SIDE: u32 = 192;

/// shrad's picture at pixel centres, and the lightmap at `res` rendered back.
fn pictures(e: &Engine, res: u32) -> (Image, Image) {
    let options = RenderOptions {
        width: SIDE,
        height: SIDE,
        spp: 1,
        shading: Shading::Smooth,
    };
    let camera = e.world().scene.camera_or_default_at(e.world().time);
    let own = e.render(Some(&camera), &options).unwrap();
    let opts = LightmapOptions {
        resolution: Some(res),
        ..LightmapOptions::default()
    };
    let l = layout(e.world(), &opts).unwrap();
    let t = texel::bake(e.world(), &shrad::lightmap::output::surface_light(e), &l);
    let back = render_back(e.world(), &l, &t.irradiance, &camera, SIDE, SIDE);
    let lit = own.pixels.iter().filter(|p| p.min_element() > 0.0).count();
    assert!(lit > own.pixels.len() / 2, "only {lit} lit pixels");
    (own, back)
}

/// The vertex-colour bake drawn back: the patches' light interpolated from their corners,
/// no light evaluated per pixel (what COLOR_0 shows).
fn vertex_picture(e: &Engine) -> Image {
    let w = e.world();
    let camera = w.scene.camera.unwrap();
    let light = SurfaceLight::new(w, e.radiosity(), &[], Shading::Smooth);
    let (origins, dirs, hits) = shrad::render::primary_hits(w, &camera, SIDE, SIDE, 1);
    let n = hits.len();
    let mut out = Image {
        width: SIDE,
        height: SIDE,
        pixels: vec![Vec3::ZERO; n],
        emitter: vec![false; n],
    };
    for k in 0..hits.len() {
        if let Some(i) = w.seen_patch(&hits[k]) {
            let (s, t) = light.params(i, origins[k] + dirs[k] * hits[k].t);
            let (rho, m) = light.albedo_and_emission(i, s, t);
            out.emitter[k] = w.exitance[i].max_element() > 0.0;
            out.pixels[k] = (rho * light.irradiance(i, s, t, None) + m) / std::f32::consts::PI;
        }
    }
    out
}

#[test]
fn rendered_back_it_matches_the_picture_on_the_cornell_box() {
    let e = engine(cornell(false), 1500);
    let (own, back) = pictures(&e, 512);
    let err = block_rmse(&own, &back);
    println!("Cornell box, 512 x 512: block RMSE {:.2} %", 100.0 * err);
    assert!(err < 0.02, "block RMSE {:.2} %", 100.0 * err);
    // It is the light, not an average: a lightmap of the wrong state is far off.
    let dark: Vec<Vec3> = own.pixels.iter().map(|p| *p * 0.9).collect();
    let off = Image {
        pixels: dark,
        ..own.clone()
    };
    assert!(block_rmse(&own, &off) > 0.05);
}

#[test]
fn with_a_point_light_it_keeps_the_shadow_edge_the_vertex_bake_smears() {
    let e = engine(cornell(true), 1500);
    let (own, back) = pictures(&e, 1024);
    let lightmap = block_rmse(&own, &back);
    let vertex = block_rmse(&own, &vertex_picture(&e));
    println!(
        "Cornell box and a point light, 1024 x 1024: lightmap {:.2} %, vertex colours {:.2} %",
        100.0 * lightmap,
        100.0 * vertex
    );
    assert!(
        lightmap < 0.02,
        "lightmap block RMSE {:.2} %",
        100.0 * lightmap
    );
    assert!(
        vertex > 2.0 * lightmap,
        "vertex bake {:.2} % vs lightmap {:.2} %",
        100.0 * vertex,
        100.0 * lightmap
    );
}

#[test]
fn rendered_back_it_matches_the_picture_on_the_blender_room() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender_room.glb");
    let scene = shrad_scene::load(&path, &Default::default()).unwrap();
    let e = engine(scene, 2000);
    let (own, back) = pictures(&e, 1024);
    let err = block_rmse(&own, &back);
    println!("Blender room, 1024 x 1024: block RMSE {:.2} %", 100.0 * err);
    assert!(err < 0.02, "block RMSE {:.2} %", 100.0 * err);
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-lightmap-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Whether 2D point `p` is strictly inside triangle `t` (either winding).
fn inside(p: Vec2, t: [Vec2; 3]) -> bool {
    let side = |a: Vec2, b: Vec2| (b - a).perp_dot(p - a);
    let s = [side(t[0], t[1]), side(t[1], t[2]), side(t[2], t[0])];
    s.iter().all(|&x| x > 1e-4) || s.iter().all(|&x| x < -1e-4)
}

#[test]
fn the_glb_has_a_second_uv_set_without_overlap_and_the_exr_beside_it() {
    let mut e = engine(cornell(false), 400);
    let d = dir("glb");
    let path = d.join("cornell.glb");
    let opts = LightmapOptions {
        resolution: Some(128),
        ..LightmapOptions::default()
    };
    let baked = shrad::lightmap::bake_with_progress(
        &mut e,
        &path,
        &BakeOptions {
            passes: 0,
            ..Default::default()
        },
        &opts,
        &NoProgress,
    )
    .unwrap();
    assert_eq!(baked.len(), 1);
    let (doc, buffers, images) = gltf::import(&path).unwrap();
    assert_eq!(images.len(), 2);
    assert!(images.iter().all(|i| (i.width, i.height) == (128, 128)));
    let material = doc.materials().next().unwrap();
    let base = material
        .pbr_metallic_roughness()
        .base_color_texture()
        .unwrap();
    assert_eq!(base.tex_coord(), 1);
    let mut count = vec![0u8; 128 * 128];
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let r = prim.reader(|b| Some(&buffers[b.index()]));
            let uv: Vec<Vec2> = r
                .read_tex_coords(1)
                .unwrap()
                .into_f32()
                .map(Vec2::from)
                .collect();
            assert!(uv
                .iter()
                .all(|q| (0.0..=1.0).contains(&q.x) && (0.0..=1.0).contains(&q.y)));
            let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
            for t in idx.chunks(3) {
                let tri = [0, 1, 2].map(|k| uv[t[k] as usize] * 128.0);
                for (k, c) in count.iter_mut().enumerate() {
                    let p = Vec2::new((k % 128) as f32 + 0.5, (k / 128) as f32 + 0.5);
                    *c += inside(p, tri) as u8;
                }
            }
        }
    }
    assert!(count.iter().all(|&c| c <= 1), "texels under two triangles");
    let covered = count.iter().filter(|&&c| c == 1).count();
    assert!(covered > 128 * 128 / 4, "only {covered} texels used");
    let exr = shrad::image_io::read_exr(&d.join("cornell.lightmap.exr")).unwrap();
    assert_eq!((exr.width, exr.height), (128, 128));
    assert!(exr.pixels.iter().any(|p| p.x > 0.0));
}

#[test]
fn bad_options_are_errors() {
    let e = engine(cornell(false), 200);
    let bad = [
        (Some(-1.0), None, "positive"),
        (Some(f32::NAN), None, "positive"),
        (Some(1e-4), None, "larger texel size"),
        (Some(1.0), Some(64), "not both"),
        (None, Some(4), "8 to"),
    ];
    for (texel_size, resolution, want) in bad {
        let o = LightmapOptions {
            texel_size,
            resolution,
            padding: 2,
            ..LightmapOptions::default()
        };
        let err = layout(e.world(), &o).unwrap_err().to_string();
        assert!(err.contains(want), "{err}");
    }
}
