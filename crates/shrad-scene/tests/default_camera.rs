//! The camera a scene without one gets: inside a room that encloses it (its faces inward,
//! or double-sided around the other objects), outside a closed object that is the whole scene (a glTF sample model's box, which the camera inside saw
//! only from behind its faces: a picture of the sky alone).

use glam::{Affine3A, Vec3};
use shrad_scene::{box_mesh, Material, Object, Role, Scene};

/// A scene of one boundary box of half size 2, facing `inward` or not, placed by `m`.
fn one_box(inward: bool, double_sided: bool, m: Affine3A) -> Scene {
    let mut material = Material::diffuse(Vec3::splat(0.8));
    material.double_sided = double_sided;
    let mut o = Object::new("box", box_mesh(Vec3::splat(2.0), inward), material);
    o.role = Some(Role::Boundary);
    o.world_from_object = m;
    Scene {
        objects: vec![o],
        ..Default::default()
    }
}

/// Whether the default camera stands inside the scene's box.
fn camera_inside(s: &Scene) -> bool {
    let eye = s.camera_or_default().world_from_camera.translation;
    let b = s.bounds().unwrap();
    (0..3).all(|a| b.min[a] < eye[a] && eye[a] < b.max[a])
}

#[test]
fn a_room_is_seen_from_inside_and_a_closed_object_from_outside() {
    let mirror = Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    for (m, what) in [(Affine3A::IDENTITY, "as it is"), (mirror, "mirrored")] {
        assert!(camera_inside(&one_box(true, false, m)), "room {what}");
        assert!(!camera_inside(&one_box(false, false, m)), "object {what}");
        // Both sides are front: a room when it holds something, else a model seen from
        // outside (a glTF model exported double-sided, as Blender does, was a picture of
        // one colour from inside its own box).
        assert!(
            !camera_inside(&one_box(false, true, m)),
            "double-sided alone {what}"
        );
        let mut room = one_box(false, true, m);
        let mut held = room.objects[0].clone();
        held.mesh = box_mesh(Vec3::splat(0.5), false);
        held.role = Some(Role::Interior);
        room.objects.push(held);
        assert!(camera_inside(&room), "double-sided holding a box {what}");
    }
}

/// A model is framed from its front and above: the +Z side, as glTF has it ("the front of
/// an asset faces +Z"; from -Z a single-sided model facing +Z, Khronos' Triangle, showed
/// only the backs of its faces), raised so that a flat floor is not seen edge-on.
#[test]
fn a_model_is_framed_from_the_plus_z_side_and_above() {
    let s = one_box(
        false,
        false,
        Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0)),
    );
    let camera = s.camera_or_default();
    let eye = Vec3::from(camera.world_from_camera.translation);
    let forward = -Vec3::from(camera.world_from_camera.matrix3.z_axis);
    let b = s.bounds().unwrap();
    assert!(eye.z > b.max.z, "eye {eye} not on the +Z side of {b:?}");
    assert!(eye.y > b.max.y, "eye {eye} not above {b:?}");
    assert!(
        forward.z < -0.8 && forward.y < -0.3,
        "looks along {forward}"
    );
    // Straight at the model's centre.
    let to_centre = (b.centre() - eye).normalize();
    assert!(forward.dot(to_centre) > 0.999, "{forward} vs {to_centre}");
    // The whole box in view: every corner within the vertical field of view.
    for k in 0..8 {
        let corner = Vec3::select(
            glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0),
            b.max,
            b.min,
        );
        let angle = forward.angle_between(corner - eye);
        assert!(angle < 0.5 * camera.yfov, "corner {corner} at {angle} rad");
    }
}

/// A flat floor facing up (an OBJ plane at y = 0) is seen from above, not edge-on (a picture
/// of the sky alone from the side).
#[test]
fn a_flat_floor_is_seen_from_above() {
    let mut material = Material::diffuse(Vec3::splat(0.8));
    material.double_sided = false;
    let quad = shrad_scene::Mesh::new(
        vec![
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, -1.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let s = Scene {
        objects: vec![Object::new("floor", quad, material)],
        ..Default::default()
    };
    let camera = s.camera_or_default();
    let eye = Vec3::from(camera.world_from_camera.translation);
    let forward = -Vec3::from(camera.world_from_camera.matrix3.z_axis);
    // The floor's normal is +Y: the camera must be above it, looking down at it.
    assert!(eye.y > 0.1, "eye {eye} level with the floor");
    assert!(forward.dot(Vec3::NEG_Y) > 0.3, "looks along {forward}");
}

/// A room of separate walls open on one side (an OBJ of the Cornell box: floor, ceiling,
/// back and side walls, open towards -Z) is seen through its opening: from +Z the camera
/// looked through the back of the far wall and saw neither the ceiling nor the light. The
/// same walls facing outward are a model, framed from its front, +Z.
#[test]
fn a_room_of_separate_walls_is_seen_through_its_opening() {
    let walls = |inward: bool| {
        let room = box_mesh(Vec3::splat(2.0), inward);
        // The box's 6 faces (4 corners and 2 triangles each) as 6 objects, the -Z one left
        // out.
        let objects = (0..6).filter_map(|f| {
            let positions = room.positions[4 * f..4 * f + 4].to_vec();
            let base = 4 * f as u32;
            let triangles = (room.triangles[2 * f..2 * f + 2].iter())
                .map(|t| t.map(|i| i - base))
                .collect();
            let mesh = shrad_scene::Mesh::new(positions, triangles);
            let open = mesh.positions.iter().all(|p| p.z < -1.9);
            let mut o = Object::new(
                format!("wall{f}"),
                mesh,
                Material::diffuse(Vec3::splat(0.8)),
            );
            o.role = Some(Role::Boundary);
            (!open).then_some(o)
        });
        Scene {
            objects: objects.collect(),
            ..Default::default()
        }
    };
    let eye = |s: &Scene| s.camera_or_default().world_from_camera.translation;
    let room = walls(true);
    assert_eq!(room.objects.len(), 5);
    let at = eye(&room);
    assert!(
        at.z < -2.0 && at.y > 0.0,
        "the eye {at}: not before the opening"
    );
    let model = walls(false);
    let at = eye(&model);
    assert!(
        at.z > 2.0 && at.y > 0.0,
        "the eye {at}: not before the front"
    );
}
