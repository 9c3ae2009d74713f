//! The camera a scene without one gets: inside a room that encloses it, outside a closed
//! object that is the whole scene (a glTF sample model's box, which the camera inside saw
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
        // Both sides are front: a room all the same.
        assert!(
            camera_inside(&one_box(false, true, m)),
            "double-sided {what}"
        );
    }
}
