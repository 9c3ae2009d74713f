//! A glTF node animation drives the patches: `World::set_time` moves an animated object's
//! patches where the node is, and a scale key changes its world area.

use glam::Vec3;
use serde_json::json;
use shrad::scene::{load, LoadOptions};
use shrad::vis::Backend;
use shrad::{PatchSizing, World};

fn b64(data: &[u8]) -> String {
    base64::encode(data)
}

/// A unit square "Grower" (scale 1 -> 2 LINEAR over 0..1 s, translation (0,0,0) ->
/// (3,0,0)) facing +Z, and a static light panel "Lamp" facing it from z = 4.
fn gltf() -> serde_json::Value {
    gltf_with([1., 2.], [0., 3.])
}

/// [`gltf`] with the Grower's scale going from `scale[0]` to `scale[1]` (uniform) and its
/// translation along x from `x[0]` to `x[1]`.
fn gltf_with(scale: [f32; 2], x: [f32; 2]) -> serde_json::Value {
    let mut bin: Vec<u8> = Vec::new();
    let mut put = |xs: &[f32]| {
        let at = bin.len();
        for x in xs {
            bin.extend_from_slice(&x.to_le_bytes());
        }
        (at, 4 * xs.len())
    };
    let pos = put(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
    let times = put(&[0.0, 1.0]);
    let scales = put(&[scale[0], scale[0], scale[0], scale[1], scale[1], scale[1]]);
    let moves = put(&[x[0], 0., 0., x[1], 0., 0.]);
    let mut idx = Vec::new();
    for i in [0u16, 1, 2, 0, 2, 3] {
        idx.extend_from_slice(&i.to_le_bytes());
    }
    let at = bin.len();
    bin.extend_from_slice(&idx);
    let view = |(o, l): (usize, usize)| json!({"buffer": 0, "byteOffset": o, "byteLength": l});
    json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "Grower", "mesh": 0},
            {"name": "Lamp", "mesh": 1, "translation": [0.0, 0.0, 4.0],
             "rotation": [1.0, 0.0, 0.0, 0.0]}
        ],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]},
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}
        ],
        "materials": [{"emissiveFactor": [1.0, 1.0, 1.0]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR",
             "min": [0.0], "max": [1.0]},
            {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"},
            {"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC3"}
        ],
        "bufferViews": [view(pos), view(times), view(scales), view(moves), view((at, 12))],
        "animations": [{"name": "GrowerAction",
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "scale"}},
                         {"sampler": 1, "target": {"node": 0, "path": "translation"}}],
            "samplers": [{"input": 2, "output": 3}, {"input": 2, "output": 4}]}],
        "buffers": [{"byteLength": bin.len(),
                     "uri": format!("data:application/octet-stream;base64,{}", b64(&bin))}]
    })
}

#[test]
fn a_scale_key_changes_the_world_area_and_a_translation_moves_the_patches() {
    let dir = std::env::temp_dir().join(format!("shrad-gltf-anim-world-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("grow.gltf");
    std::fs::write(&path, serde_json::to_string(&gltf()).unwrap()).unwrap();
    let scene = load(&path, &LoadOptions::default()).unwrap();
    let grower = scene
        .objects
        .iter()
        .position(|o| o.name == "Grower")
        .unwrap();
    assert!(scene.objects[grower].is_animated());
    assert_eq!(scene.duration(), 1.0);
    let mut world = World::new(scene, PatchSizing::Size(0.25), Backend::Auto).unwrap();
    let range = world.patches.range(grower);
    let area = |w: &World| range.clone().map(|p| w.patches.area[p]).sum::<f32>();
    let centre =
        |w: &World| range.clone().map(|p| w.patches.centre[p]).sum::<Vec3>() / range.len() as f32;
    assert!((area(&world) - 1.0).abs() < 1e-4, "{}", area(&world));
    assert!((centre(&world) - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-4);
    // t = 0.5: scale 1.5 (area 2.25), origin at (1.5, 0, 0), centre (1.5 + 0.75, 0.75, 0).
    let (moved, _) = world.set_time(0.5).unwrap();
    assert_eq!(moved, vec![grower]);
    assert!((area(&world) - 2.25).abs() < 1e-3, "{}", area(&world));
    let c = centre(&world);
    assert!((c - Vec3::new(2.25, 0.75, 0.0)).length() < 1e-4, "{c}");
    // t = 1 and after: scale 2, area 4.
    world.set_time(1.0).unwrap();
    assert!((area(&world) - 4.0).abs() < 1e-3, "{}", area(&world));
    let (moved, _) = world.set_time(3.0).unwrap();
    assert!(
        moved.is_empty(),
        "nothing moves after the last key: {moved:?}"
    );
    assert!((area(&world) - 4.0).abs() < 1e-3);
    // Back to the start: the rest patches again.
    world.set_time(0.0).unwrap();
    assert!((area(&world) - 1.0).abs() < 1e-4, "{}", area(&world));
    // The normals still face +Z.
    assert!(range
        .clone()
        .all(|p| (world.patches.normal[p] - Vec3::Z).length() < 1e-5));
}

/// Load `json` as a scene file in a directory of its own.
fn world_of(json: &serde_json::Value, name: &str) -> World {
    let dir = std::env::temp_dir().join(format!("shrad-gltf-anim-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("grow.gltf");
    std::fs::write(&path, serde_json::to_string(json).unwrap()).unwrap();
    let scene = load(&path, &LoadOptions::default()).unwrap();
    World::new(scene, PatchSizing::Size(0.25), Backend::Auto).unwrap()
}

/// A mirror animated (scale 1 -> -1) passes through a scale of 0 halfway: the pose there
/// is raised to a sliver (as a zero key is), never a singular transform (which made Embree
/// abort on the rays it gave).
#[test]
fn a_scale_animated_through_zero_is_a_sliver_not_a_collapse() {
    let mut world = world_of(&gltf_with([1., -1.], [0., 0.]), "mirror");
    let range = world.patches.range(0);
    world.set_time(0.5).unwrap();
    let p = &world.patches;
    assert!(range
        .clone()
        .all(|i| p.centre[i].is_finite() && p.normal[i].is_finite()));
    let area: f32 = range.clone().map(|i| p.area[i]).sum();
    assert!(area > 0.0 && area < 1e-6, "{area}");
    // The backend takes rays about it.
    let (o, d) = ([Vec3::new(0.0, 0.5, 1.0)], [Vec3::NEG_Z]);
    let mut hits = vec![shrad::vis::Hit::MISS; 1];
    world.vis.closest(&o, &d, 0.0, &[], &mut hits);
    world.set_time(1.0).unwrap();
    let area: f32 = range.clone().map(|i| world.patches.area[i]).sum();
    assert!((area - 1.0).abs() < 1e-4, "{area}");
}

/// An animation that throws an object beyond the coordinates 32-bit floats can hold is an
/// error naming the object and the time, and nothing moves; the times before it play.
#[test]
fn an_animation_beyond_the_coordinates_a_solve_holds_is_an_error() {
    let mut world = world_of(&gltf_with([1., 1.], [0., 3e38]), "far");
    let range = world.patches.range(0);
    let before: Vec<Vec3> = range.clone().map(|i| world.patches.centre[i]).collect();
    let e = world.set_time(1.0).unwrap_err().to_string();
    assert!(
        e.contains("'Grower'") && e.contains("time 1 s") && e.contains("1e12"),
        "{e}"
    );
    assert!(world.check_time(1.0).is_err());
    let after: Vec<Vec3> = range.clone().map(|i| world.patches.centre[i]).collect();
    assert_eq!(before, after);
    // 3e38 * 1e-30 = 3e8 along x: far, but within what a solve holds.
    world.set_time(1e-30).unwrap();
}
