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

/// A model is framed from its front, the +Z side looking towards -Z, as glTF has it ("the
/// front of an asset faces +Z"): from -Z a single-sided model facing +Z (Khronos' Triangle)
/// showed only the backs of its faces, a picture of the sky alone.
#[test]
fn a_model_is_framed_from_the_plus_z_side() {
    let s = one_box(
        false,
        false,
        Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0)),
    );
    let camera = s.camera_or_default();
    let eye = camera.world_from_camera.translation;
    let forward = -Vec3::from(camera.world_from_camera.matrix3.z_axis);
    let b = s.bounds().unwrap();
    assert!(eye.z > b.max.z, "eye {eye} not on the +Z side of {b:?}");
    assert!(forward.dot(Vec3::NEG_Z) > 0.999, "looks along {forward}");
    // Straight at the model's centre.
    let to_centre = (b.centre() - Vec3::from(eye)).normalize();
    assert!(forward.dot(to_centre) > 0.999, "{forward} vs {to_centre}");
}
