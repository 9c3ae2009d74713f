//! Linked duplicates that Blender's glTF exporter writes as one instanced node
//! (`tests/data/blender/gpu_instances.py`, "GPU Instances": `EXT_mesh_gpu_instancing`), with
//! where Blender has each duplicate's vertices (`gpu_instances.json`): every instance shrad
//! makes of the node must have its vertices where Blender has one duplicate's, and each
//! duplicate must be drawn once. With /tmp/bpyenv (Blender as the bpy module) the fixture is
//! rebuilt by Blender first and checked too.
//!
//! The same file rewritten by gltfpack (`gpu_instances_gltfpack.glb`: `gltfpack -i
//! gpu_instances.glb -o gpu_instances_gltfpack.glb -cc -mi -kn`, gltfpack 1.x from npm) has
//! the extension required, its accessors in meshopt-compressed views (TRANSLATION and SCALE
//! with the EXPONENTIAL filter, ROTATION with the QUATERNION filter) and quantized
//! positions; its instances must land in the same places.
//!
//! Before shrad read the extension the node drew its mesh once, at the empty's transform;
//! and before shrad decoded the QUATERNION filter itself, meshopt-rs read its components as
//! unsigned, which put every instance whose rotation has a negative component elsewhere.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;
use shrad_scene::{load, LoadOptions};

use crate::common::blender::{check_fresh_export, data};

/// How far (m) a vertex of Blender's float export may be from Blender's: rounding.
const FLOATS: f32 = 1e-4;
/// And of gltfpack's: its positions are on a 1.2 mm grid, scaled up to 3x by the instances,
/// and its rotations quantized (the largest cube, 3 m across, is 1.3 cm off). shrad's decode
/// of the instances' accessors equals meshoptimizer's own decoder's (its npm package's
/// `MeshoptDecoder.decodeGltfBuffer`, compared by hand); the QUATERNION filter's bug put
/// instances metres off.
const QUANTIZED: f32 = 2e-2;

/// Each duplicate's vertices as Blender has them.
fn blender_crates(json: &Path) -> Vec<(String, Vec<Vec3>)> {
    let v: Value = serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let point = |p: &Value| {
        let c: Vec<f32> = (0..3).map(|k| p[k].as_f64().unwrap() as f32).collect();
        Vec3::from_slice(&c)
    };
    v["crates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let name = c["name"].as_str().unwrap().to_string();
            (
                name,
                c["vertices"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(point)
                    .collect(),
            )
        })
        .collect()
}

/// The largest distance from a point of `a` to the nearest of `b`.
fn farthest(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .map(|p| {
            b.iter()
                .map(|q| p.distance(*q))
                .fold(f32::INFINITY, f32::min)
        })
        .fold(0.0, f32::max)
}

/// Check `glb` against Blender's `json`; `tol`: how far (m) a vertex may be from Blender's.
fn check(glb: &Path, json: &Path, tol: f32) {
    let scene = load(glb, &LoadOptions::default()).unwrap();
    let instances: Vec<Vec<Vec3>> = (scene.objects.iter())
        .filter(|o| o.name.contains('#'))
        .map(|o| {
            let m = o.world_from_object;
            o.mesh
                .positions
                .iter()
                .map(|&p| m.transform_point3(p))
                .collect()
        })
        .collect();
    let crates = blender_crates(json);
    assert_eq!(instances.len(), crates.len(), "one instance per duplicate");
    let mut matched = vec![false; instances.len()];
    for (name, blender) in &crates {
        // The instance whose vertices are Blender's (both ways: the exporter splits
        // vertices by face, so shrad's are more, at the same places).
        let off = |k: usize| farthest(&instances[k], blender).max(farthest(blender, &instances[k]));
        let k = (0..instances.len())
            .min_by(|&a, &b| off(a).total_cmp(&off(b)))
            .filter(|&k| off(k) < tol)
            .unwrap_or_else(|| panic!("{}: no instance within {tol} m of {name}", glb.display()));
        eprintln!(
            "{}: {name} is instance {k}, {:.1e} m off",
            glb.display(),
            off(k)
        );
        assert!(!matched[k], "{name}: instance {k} matched twice");
        matched[k] = true;
    }
}

#[test]
fn shrad_puts_each_instance_where_blender_has_its_duplicate() {
    check(
        &data().join("gpu_instances.glb"),
        &data().join("gpu_instances.json"),
        FLOATS,
    );
}

#[test]
fn gltfpacks_compressed_instances_land_where_blender_has_them() {
    check(
        &data().join("gpu_instances_gltfpack.glb"),
        &data().join("gpu_instances.json"),
        QUANTIZED,
    );
}

#[test]
fn fresh_blender_instancing_export_when_blender_is_installed() {
    check_fresh_export("gpu_instances", |glb: &Path, json: &Path| {
        check(glb, json, FLOATS)
    });
}
