//! Linked duplicates that Blender's glTF exporter writes as one instanced node
//! (`tests/data/blender/gpu_instances.py`, "GPU Instances": `EXT_mesh_gpu_instancing`), with
//! where Blender has each duplicate's vertices (`gpu_instances.json`): every instance shrad
//! makes of the node must have its vertices where Blender has one duplicate's, and each
//! duplicate must be drawn once. With /tmp/bpyenv (Blender as the bpy module) the fixture is
//! rebuilt by Blender first and checked too.
//!
//! Before shrad read the extension the node drew its mesh once, at the empty's transform.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;
use shrad_scene::{load, LoadOptions};

use crate::common::blender::{data, run_script};

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

fn check(glb: &Path, json: &Path) {
    let scene = load(glb, &LoadOptions::default()).unwrap();
    let instances: Vec<Vec<Vec3>> = (scene.objects.iter())
        .filter(|o| o.name.starts_with("Forest#"))
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
        let k = (0..instances.len())
            .find(|&k| {
                farthest(&instances[k], blender) < 1e-4 && farthest(blender, &instances[k]) < 1e-4
            })
            .unwrap_or_else(|| panic!("{}: no instance where Blender has {name}", glb.display()));
        assert!(!matched[k], "{name}: instance {k} matched twice");
        matched[k] = true;
    }
}

#[test]
fn shrad_puts_each_instance_where_blender_has_its_duplicate() {
    check(
        &data().join("gpu_instances.glb"),
        &data().join("gpu_instances.json"),
    );
}

#[test]
fn fresh_blender_instancing_export_when_blender_is_installed() {
    let out = std::env::temp_dir().join(format!("shrad-blender-inst-{}", std::process::id()));
    if !run_script(&data().join("gpu_instances.py"), &out, &[]) {
        return;
    }
    check(
        &out.join("gpu_instances.glb"),
        &out.join("gpu_instances.json"),
    );
    let _ = std::fs::remove_dir_all(&out);
}
