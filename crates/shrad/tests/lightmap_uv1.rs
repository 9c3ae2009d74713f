//! A lightmap over the file's own `TEXCOORD_1`: a floor whose two triangles are two islands
//! of a hand-made UV layout (opposite corners of the UV square, the second turned half a
//! turn) bakes with each texel where those UVs put it: the written `TEXCOORD_1` is the
//! user's layout under one scale and offset, the light read back through the user's UVs is
//! the point light's exact `I cos / d^2` shape, and the empty part of the layout stays
//! black. A layout whose triangles overlap is refused with a warning naming the object, and
//! the object gets generated charts instead.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Vec2, Vec3};
use serde_json::json;
use shrad::bake::BakeOptions;
use shrad::engine::Engine;
use shrad::lightmap::texel::bilinear;
use shrad::lightmap::uv_chart::triangles_overlap;
use shrad::lightmap::LightmapOptions;
use shrad::solver::SolverChoice;
use shrad::{NoProgress, PatchSizing};
use shrad_scene::gltf_builder::{bounds, join_glb, BufferAt, GltfBuffer, TRIANGLES};
use shrad_scene::{Light, LightKind};

/// The point light's position: over the floor's `(x, z) = (0.25, 0.6)`, 0.5 m up.
const BULB: Vec3 = Vec3::new(0.25, 0.5, 0.6);

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-lmuv1-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The floor's corners `(x, z)`: triangle A is `p0 p1 p2` (where `z > x`), B `p0 p2 p3`.
const P: [Vec2; 4] = [
    Vec2::new(0.0, 0.0),
    Vec2::new(0.0, 1.0),
    Vec2::new(1.0, 1.0),
    Vec2::new(1.0, 0.0),
];

/// The hand-made layout: A in `[0.05, 0.45]^2`, B in `[0.55, 0.95]^2` turned half a turn.
fn layout_uv(x: f32, z: f32) -> Vec2 {
    if z >= x {
        Vec2::new(0.05 + 0.4 * x, 0.05 + 0.4 * z)
    } else {
        Vec2::new(0.95 - 0.4 * z, 0.95 - 0.4 * x)
    }
}

/// A 1 m floor (y = 0, facing +Y), its two triangles unwelded, with TEXCOORD_1 `uv1` for
/// its six vertices (A's three, then B's), written as a GLB to `path`.
fn write_floor(path: &Path, uv1: [Vec2; 6]) {
    let corner = |k: usize| Vec3::new(P[k].x, 0.0, P[k].y);
    let positions: Vec<Vec3> = [0, 1, 2, 0, 2, 3].map(corner).to_vec();
    let mut b = GltfBuffer::new();
    let (lo, hi) = bounds(&positions);
    let pos = b.vec3s(
        &positions,
        Some((json!(lo.to_array()), json!(hi.to_array()))),
    );
    let uv0 = b.vec2s(&[Vec2::ZERO; 6]);
    let uv = b.vec2s(&uv1);
    let idx = b.triangles(&[[0, 1, 2], [3, 4, 5]]);
    let buffer = b.finish(BufferAt::Glb);
    let root = json!({
        "asset": {"version": "2.0"},
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "floor", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv0, "TEXCOORD_1": uv},
                                     "indices": idx, "material": 0, "mode": TRIANGLES}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}}],
        "accessors": buffer.accessors, "bufferViews": buffer.buffer_views, "buffers": buffer.buffers,
    });
    let glb = join_glb(serde_json::to_vec(&root).unwrap(), buffer.bin).unwrap();
    std::fs::write(path, glb).unwrap();
}

/// The user's layout at the six vertices.
fn good_uv1() -> [Vec2; 6] {
    // A's vertices are on its own side of the diagonal; B's p0 and p2 are on the diagonal,
    // where B's formula is the limit from its side.
    let b = |x: f32, z: f32| Vec2::new(0.95 - 0.4 * z, 0.95 - 0.4 * x);
    [0, 1, 2]
        .map(|k| layout_uv(P[k].x, P[k].y))
        .into_iter()
        .chain([b(0.0, 0.0), b(1.0, 1.0), b(1.0, 0.0)])
        .collect::<Vec<_>>()
        .try_into()
        .unwrap()
}

/// Bake the floor at `path` lit by the bulb into `out` (128 x 128): the file's warnings.
fn bake(path: &Path, out: &Path) -> Vec<String> {
    let mut scene = shrad_scene::load(path, &Default::default()).unwrap();
    scene.lights.push(Light {
        world_from_light: Affine3A::from_translation(BULB),
        ..Light::new("bulb", LightKind::Point, 683.0 * 10.0)
    });
    let mut e = Engine::new(
        scene,
        PatchSizing::Count(200),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    e.step();
    let opts = LightmapOptions {
        resolution: Some(128),
        ..LightmapOptions::default()
    };
    let options = BakeOptions {
        passes: 0,
        ..Default::default()
    };
    let baked =
        shrad::lightmap::bake_with_progress(&mut e, out, &options, &opts, &NoProgress).unwrap();
    baked[0].warnings.clone()
}

/// Each output triangle's world corners and TEXCOORD_1.
fn output_triangles(out: &Path) -> Vec<([Vec3; 3], [Vec2; 3])> {
    let (doc, buffers, _) = gltf::import(out).unwrap();
    let mut tris = Vec::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let r = prim.reader(|b| Some(&buffers[b.index()]));
            let pos: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
            let uv: Vec<Vec2> = r
                .read_tex_coords(1)
                .unwrap()
                .into_f32()
                .map(Vec2::from)
                .collect();
            let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
            for t in idx.chunks(3) {
                let k = [0, 1, 2].map(|j| t[j] as usize);
                tris.push((k.map(|i| pos[i]), k.map(|i| uv[i])));
            }
        }
    }
    tris
}

#[test]
fn the_texels_are_where_the_file_s_own_uvs_put_them() {
    let d = dir("good");
    let (input, out) = (d.join("floor.glb"), d.join("out.glb"));
    write_floor(&input, good_uv1());
    let warnings = bake(&input, &out);
    assert!(warnings.is_empty(), "{warnings:?}");

    // The written TEXCOORD_1 is the user's layout under one scale and one offset.
    let pairs: Vec<(Vec2, Vec2)> = output_triangles(&out)
        .iter()
        .flat_map(|(p, uv)| {
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let a_side = c.z >= c.x;
            (0..3).map(move |k| {
                let (x, z) = (p[k].x, p[k].z);
                let mine = if a_side {
                    Vec2::new(0.05 + 0.4 * x, 0.05 + 0.4 * z)
                } else {
                    Vec2::new(0.95 - 0.4 * z, 0.95 - 0.4 * x)
                };
                (mine, uv[k])
            })
        })
        .collect();
    assert!(pairs.len() >= 6);
    let (lo_in, hi_in) = pairs
        .iter()
        .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(a, b), p| {
            (a.min(p.0), b.max(p.0))
        });
    let (lo_out, hi_out) = pairs
        .iter()
        .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let scale = (hi_out - lo_out) / (hi_in - lo_in);
    assert!(
        (scale.x - scale.y).abs() < 1e-4 * scale.x,
        "not one scale: {scale}"
    );
    for (mine, got) in &pairs {
        let want = lo_out + (*mine - lo_in) * scale;
        assert!(
            (want - *got).abs().max_element() < 1e-4,
            "{mine} -> {got}, want {want}"
        );
    }

    // The light read through the user's UVs is the bulb's: E / pi relative to a reference
    // point follows h / d^3 (the floor sees nothing else), within 2 %.
    let exr = shrad::image_io::read_exr(&shrad::lightmap::output::exr_path(&out)).unwrap();
    let size = Vec2::new(exr.width as f32, exr.height as f32);
    let at = |uv: Vec2| {
        let atlas = (lo_out + (uv - lo_in) * scale) * size;
        bilinear(&exr.pixels, exr.width, exr.height, atlas).x
    };
    let shape = |x: f32, z: f32| {
        let d = BULB - Vec3::new(x, 0.0, z);
        BULB.y / d.length().powi(3)
    };
    let (x0, z0) = (0.2, 0.7);
    let reference = at(layout_uv(x0, z0));
    assert!(reference > 0.0);
    for (x, z) in [
        (0.1, 0.3),
        (0.2, 0.9),
        (0.5, 0.8),
        (0.35, 0.6),
        (0.3, 0.1),
        (0.9, 0.2),
        (0.8, 0.6),
        (0.6, 0.4),
    ] {
        let got = at(layout_uv(x, z)) / reference;
        let want = shape(x, z) / shape(x0, z0);
        println!("({x}, {z}): lightmap {got:.4}, I cos / d^2 {want:.4}");
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "({x}, {z}): {got} vs {want}"
        );
    }
    // The layout's empty corners are no one's texels.
    for empty in [Vec2::new(0.75, 0.2), Vec2::new(0.2, 0.8)] {
        let xy = (lo_out + (empty - lo_in) * scale) * size;
        assert_eq!(
            bilinear(&exr.pixels, exr.width, exr.height, xy),
            Vec3::ZERO,
            "{empty}"
        );
    }
}

#[test]
fn overlapping_uvs_warn_naming_the_object_and_charts_are_generated() {
    let d = dir("bad");
    let (input, out) = (d.join("floor.glb"), d.join("out.glb"));
    let mut uv1 = good_uv1();
    // B laid over A.
    uv1[3] = uv1[0];
    uv1[4] = uv1[2];
    uv1[5] = Vec2::new(0.1, 0.4);
    write_floor(&input, uv1);
    let warnings = bake(&input, &out);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("object 'floor'")
            && warnings[0].contains("overlap")
            && warnings[0].contains("charts generated"),
        "{}",
        warnings[0]
    );
    let tris = output_triangles(&out);
    for (a, ta) in tris.iter().enumerate() {
        for tb in &tris[..a] {
            assert!(
                !triangles_overlap(ta.1, tb.1, 1e-6),
                "generated charts overlap"
            );
        }
    }
}
