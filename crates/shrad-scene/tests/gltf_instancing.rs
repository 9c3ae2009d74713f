//! `EXT_mesh_gpu_instancing`: a node that draws its mesh once per instance, each at the
//! node's world transform times the instance's `T * R * S` (the extension's specification).
//!
//! The fixture ([`instanced`]) is one triangle (0,0,0), (1,0,0), (0,1,0) drawn by node
//! "Tree" (translation (10, 0, 0), uniform scale 2) with three instances:
//! - 0: the identity;
//! - 1: T (5, 0, 0), a quarter turn about +z (Rz(90) (x, y, z) = (-y, x, z));
//! - 2: T (0, 5, 0), S (-1, 1, 1) (a mirror).
//!
//! Where vertex (1, 0, 0) lands, in closed form (`world = T(10,0,0) S(2) T_i R_i S_i`):
//! - 0: 2 (1, 0, 0) + (10, 0, 0) = (12, 0, 0);
//! - 1: Rz(90) (1, 0, 0) = (0, 1, 0), + (5, 0, 0) = (5, 1, 0), x2 + (10, 0, 0) = (20, 2, 0);
//! - 2: (-1, 0, 0) + (0, 5, 0) = (-1, 5, 0), x2 + (10, 0, 0) = (8, 10, 0).
//!
//! Before the extension was read the file drew one triangle (the node's, once), with a
//! warning that the extension was ignored; with it in `extensionsRequired` the file was
//! refused.

use glam::Vec3;
use serde_json::{json, Value};
use shrad_scene::Scene;

use crate::common::gltf_bin::Bin;
use crate::common::{err_of, gltf_json_file, load_gltf_json};

const SUITE: &str = "instancing";

/// Where vertex (1, 0, 0) of each instance lands (see the module's documentation).
const EXPECTED: [[f32; 3]; 3] = [[12.0, 0.0, 0.0], [20.0, 2.0, 0.0], [8.0, 10.0, 0.0]];

impl Bin {
    /// A normalized SHORT VEC4 accessor of unit quaternions `data` (as
    /// KHR_mesh_quantization and the extension allow for ROTATION).
    fn short_quaternions(&mut self, data: &[[f32; 4]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|x| ((x * 32767.0).round() as i16).to_le_bytes())
            .collect();
        self.accessor(
            &bytes,
            data.len(),
            "VEC4",
            5122,
            json!({"normalized": true}),
        )
    }
}

/// A quarter turn about +z as a quaternion (x, y, z, w).
fn quarter_turn_z() -> [f32; 4] {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    [0.0, 0.0, h, h]
}

/// The fixture: `rotations` gives the ROTATION accessor (the builder, the three
/// quaternions); `animated`: node "Tree" moves from x = 10 at t = 0 to x = 30 at t = 1.
fn instanced(rotations: impl Fn(&mut Bin, &[[f32; 4]]) -> usize, animated: bool) -> Value {
    let mut b = Bin::default();
    let pos = b.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let idx = b.indices(&[0, 1, 2]);
    let t = b.floats_of("VEC3", &[0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 5.0, 0.0]);
    let id = [0.0, 0.0, 0.0, 1.0];
    let r = rotations(&mut b, &[id, quarter_turn_z(), id]);
    let s = b.floats_of("VEC3", &[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -1.0, 1.0, 1.0]);
    let mut root = json!({
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{
            "name": "Tree", "mesh": 0, "translation": [10.0, 0.0, 0.0], "scale": [2.0, 2.0, 2.0],
            "extensions": {"EXT_mesh_gpu_instancing": {
                "attributes": {"TRANSLATION": t, "ROTATION": r, "SCALE": s, "_ID": t}
            }}
        }],
        "meshes": [{"name": "Leaf", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}]
    });
    if animated {
        let times = b.floats_of("SCALAR", &[0.0, 1.0]);
        let moves = b.floats_of("VEC3", &[10.0, 0.0, 0.0, 30.0, 0.0, 0.0]);
        root["animations"] = json!([{
            "name": "Walk",
            "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
            "samplers": [{"input": times, "output": moves, "interpolation": "LINEAR"}]
        }]);
    }
    b.finish(root)
}

fn float_rotations(b: &mut Bin, q: &[[f32; 4]]) -> usize {
    let flat: Vec<f32> = q.iter().flatten().copied().collect();
    b.floats_of("VEC4", &flat)
}

/// Where vertex 1 of `scene`'s object `k` lands at time `t`.
fn vertex_1(scene: &Scene, k: usize, t: f32) -> Vec3 {
    let o = &scene.objects[k];
    o.world_from_object_at(t)
        .transform_point3(o.mesh.positions[1])
}

fn assert_near(got: Vec3, want: [f32; 3], tol: f32, what: &str) {
    assert!(
        got.distance(Vec3::from(want)) < tol,
        "{what}: got {got}, want {want:?}"
    );
}

#[test]
fn each_instance_is_an_object_at_the_node_times_its_own_transform() {
    let s = load_gltf_json(SUITE, "float", &instanced(float_rotations, false));
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Tree#0", "Tree#1", "Tree#2"]);
    for (k, want) in EXPECTED.iter().enumerate() {
        assert_near(vertex_1(&s, k, 0.0), *want, 1e-5, &format!("instance {k}"));
    }
    // The mirror is kept as it is (a determinant below zero, as for a mirrored node).
    assert!(s.objects[2].world_from_object.matrix3.determinant() < 0.0);
    assert!(
        !s.warnings
            .iter()
            .any(|w| w.contains("EXT_mesh_gpu_instancing")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn quantized_rotations_and_a_required_extension_load() {
    let mut v = instanced(|b, q| b.short_quaternions(q), false);
    v["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    let s = load_gltf_json(SUITE, "short", &v);
    assert_eq!(s.objects.len(), 3);
    for (k, want) in EXPECTED.iter().enumerate() {
        // A normalized short is within 1 / 32767 of the quaternion's components.
        assert_near(vertex_1(&s, k, 0.0), *want, 1e-3, &format!("instance {k}"));
    }
}

#[test]
fn instances_follow_their_nodes_animation() {
    let s = load_gltf_json(SUITE, "animated", &instanced(float_rotations, true));
    assert_eq!(s.objects.len(), 3);
    for (k, want) in EXPECTED.iter().enumerate() {
        assert_near(
            vertex_1(&s, k, 0.0),
            *want,
            1e-5,
            &format!("instance {k} at 0"),
        );
        // At t = 1 the node is 20 further along x; the instance keeps its place in it.
        let moved = [want[0] + 20.0, want[1], want[2]];
        assert_near(
            vertex_1(&s, k, 1.0),
            moved,
            1e-4,
            &format!("instance {k} at 1"),
        );
    }
}

/// The fixture with `change` applied, loaded: the error as a user reads it.
fn refused(name: &str, change: impl Fn(&mut Value)) -> String {
    let mut v = instanced(float_rotations, false);
    change(&mut v);
    let p = gltf_json_file(SUITE, name, &v);
    let e = err_of(shrad_scene::load(&p, &shrad_scene::LoadOptions::default()));
    assert!(e.contains(&p.display().to_string()), "{e}");
    e
}

#[test]
fn malformed_instancing_is_refused_naming_the_node_and_attribute() {
    let ext = "/nodes/0/extensions/EXT_mesh_gpu_instancing/attributes";
    // SCALE pointing at the ROTATION accessor (a VEC4).
    let e = refused("wrong-type", |v| {
        let r = v.pointer(&format!("{ext}/ROTATION")).unwrap().clone();
        *v.pointer_mut(&format!("{ext}/SCALE")).unwrap() = r;
    });
    assert!(
        e.contains("nodes[0].extensions.EXT_mesh_gpu_instancing.attributes.SCALE"),
        "{e}"
    );
    assert!(e.contains("VEC4"), "{e}");
    // An accessor that does not exist.
    let e = refused("no-accessor", |v| {
        *v.pointer_mut(&format!("{ext}/TRANSLATION")).unwrap() = json!(99);
    });
    assert!(e.contains("TRANSLATION: 99 is not an accessor"), "{e}");
    // Attributes of different counts.
    let e = refused("counts", |v| {
        let t = v
            .pointer(&format!("{ext}/TRANSLATION"))
            .unwrap()
            .as_u64()
            .unwrap();
        v["accessors"][t as usize]["count"] = json!(2);
    });
    assert!(e.contains("one element per instance"), "{e}");
    // No attribute the extension defines.
    let e = refused("none", |v| {
        *v.pointer_mut(ext).unwrap() = json!({"_ID": 0});
    });
    assert!(e.contains("at least one"), "{e}");
}

#[test]
fn a_zero_rotation_is_refused_naming_the_instance() {
    let v = instanced(
        |b, q| {
            let mut q = q.to_vec();
            q[1] = [0.0; 4];
            float_rotations(b, &q)
        },
        false,
    );
    let p = gltf_json_file(SUITE, "zero-rotation", &v);
    let e = err_of(shrad_scene::load(&p, &shrad_scene::LoadOptions::default()));
    assert!(
        e.contains("instance 1's rotation is a zero quaternion"),
        "{e}"
    );
}
