//! A contact shadow (issue 22): a box standing on the floor of a closed room under a ceiling
//! light. The dispersive default, converged, against the reference solver on the same
//! patches: the box's own error (interior) and the error of the floor next to the box (the
//! contact shadow, which 8 probes at the box's corners cannot hold exactly) are bounded, and
//! a wrong reference (the floor darker by 20 %) breaks the bound, so the check can fail.

use glam::{Affine3A, Quat, Vec3};
use shrad::dispersive::{Dispersive, DispersiveOptions};
use shrad::metrics::relative_error;
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::{box_mesh, Material, Mesh, Object, Role, Scene};
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

/// Room 4 x 3 x 4 (floor at y = 0), box 0.8 x 0.8 x 0.8 on the floor off centre.
const BOX_HALF: f32 = 0.4;
const BOX_AT: Vec3 = Vec3::new(0.6, BOX_HALF, -0.3);
/// "Near the box": floor patches within this distance of its footprint (and outside it).
const NEAR: f32 = 0.5;

// Bounds, with margin over what was measured (2500 patches): interior 8.8 % and floor near
// the box 8.1 % when the test was written (2026-12, the default with `wall_smoothing`);
// interior 5.6 % and floor 7.9 % with the near field and `repair=move_out` (issue 22 item
// 1, 2026-12-03); interior 5.5 % and floor 6.0 % with Step 3's faces split
// (`emitter_split=2`, 2026-12-03). The interior bound fails with `near_rays=0
// repair=move_inward`, the floor's with `emitter_split=1` (7.9 %).
const INTERIOR_BOUND: f64 = 0.07;
const FLOOR_NEAR_BOUND: f64 = 0.07;
/// The block's top with a rider on it: measured 1.57 % (3.30 % with the near field traced
/// from the patch centres alone, before 2026-12-03, which this bound fails).
const RIDER_TOP_BOUND: f64 = 0.025;

fn scene() -> Scene {
    let mut room = Object::new(
        "room",
        box_mesh(Vec3::splat(0.5), true),
        Material::diffuse(Vec3::new(0.7, 0.7, 0.7)),
    );
    room.role = Some(Role::Boundary);
    room.world_from_object = Affine3A::from_scale_rotation_translation(
        Vec3::new(4.0, 3.0, 4.0),
        Quat::IDENTITY,
        Vec3::new(0.0, 1.5, 0.0),
    );
    // A ceiling light facing down, 1 cm below the ceiling.
    let mut light = Object::new(
        "light",
        Mesh {
            positions: vec![
                Vec3::new(-0.4, 2.99, -0.4),
                Vec3::new(0.4, 2.99, -0.4),
                Vec3::new(0.4, 2.99, 0.4),
                Vec3::new(-0.4, 2.99, 0.4),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        },
        Material {
            reflectance: Vec3::ZERO,
            emitted_radiance: Vec3::splat(10.0),
            double_sided: false,
            ..Default::default()
        },
    );
    light.role = Some(Role::Light);
    let mut block = Object::new(
        "block",
        box_mesh(Vec3::splat(BOX_HALF), false),
        Material::diffuse(Vec3::new(0.6, 0.5, 0.3)),
    );
    block.role = Some(Role::Interior);
    block.world_from_object = Affine3A::from_translation(BOX_AT);
    Scene {
        source: "contact shadow".into(),
        objects: vec![room, light, block],
        ..Default::default()
    }
}

/// Floor patches near the box but not under it.
fn floor_near_box(world: &World) -> Vec<usize> {
    let p = &world.patches;
    (0..p.len())
        .filter(|&i| {
            let (c, n) = (p.centre[i], p.normal[i]);
            let d = (Vec3::new(c.x, BOX_AT.y, c.z) - BOX_AT).abs() - Vec3::splat(BOX_HALF);
            let outside = d.x > 0.0 || d.z > 0.0;
            let distance = d.max(Vec3::ZERO).length();
            p.role(i) == Role::Boundary && n.y > 0.9 && c.y < 0.01 && outside && distance < NEAR
        })
        .collect()
}

/// Area-weighted relative L2 error over `patches`.
fn error_over(world: &World, patches: &[usize], b: &[Vec3], reference: &[Vec3]) -> f64 {
    let a = &world.patches.area;
    let (num, den) = patches.iter().fold((0f64, 0f64), |(x, y), &i| {
        let w = a[i] as f64;
        (
            x + w * (b[i] - reference[i]).length_squared() as f64,
            y + w * reference[i].length_squared() as f64,
        )
    });
    (num / den).sqrt()
}

#[test]
fn contact_shadow_and_box_are_near_the_reference() {
    let world = World::new(scene(), PatchSizing::Count(2500), Backend::Auto).unwrap();
    let (reference, _) = solve(&world, &ReferenceOptions::default(), &NoProgress);
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
    d.converge(&world, 8);
    let b = d.radiosity();
    let near = floor_near_box(&world);
    assert!(
        near.len() > 40,
        "only {} floor patches near the box",
        near.len()
    );

    let interior = relative_error(&world.patches, b, &reference).interior;
    let floor = error_over(&world, &near, b, &reference);
    println!(
        "interior {:.2} %, floor near the box {:.2} %",
        100.0 * interior,
        100.0 * floor
    );
    assert!(interior < INTERIOR_BOUND, "interior error {interior}");
    assert!(floor < FLOOR_NEAR_BOUND, "floor-near-the-box error {floor}");

    // The check can fail: against a floor 20 % too dark, the floor's error breaks its bound.
    let darker: Vec<Vec3> = (0..reference.len())
        .map(|i| match near.contains(&i) {
            true => reference[i] * 0.8,
            false => reference[i],
        })
        .collect();
    assert!(error_over(&world, &near, b, &darker) > FLOOR_NEAR_BOUND);
}

/// A small box rotated 30 degrees about y, standing on the block's top off its centre: it
/// covers parts of the top's patches (the animated Blender room's `rider`).
fn scene_with_rider() -> Scene {
    let mut scene = scene();
    let mut rider = Object::new(
        "rider",
        box_mesh(Vec3::splat(0.15), false),
        Material::diffuse(Vec3::new(0.3, 0.6, 0.3)),
    );
    rider.role = Some(Role::Interior);
    rider.world_from_object = Affine3A::from_rotation_translation(
        Quat::from_rotation_y(30f32.to_radians()),
        BOX_AT + Vec3::new(0.13, BOX_HALF + 0.15, 0.07),
    );
    scene.objects.push(rider);
    scene
}

/// The block's top face, the rider on it: patches partly covered see their cover from the
/// covered part and the room from the rest, as the reference's rays (spread over the patch)
/// do. With the near field traced from the patch centres alone, a patch whose centre is
/// covered got no reflected light at all and one whose centre is open got all of it.
#[test]
fn a_face_partly_covered_by_a_rider_is_near_the_reference() {
    let world = World::new(scene_with_rider(), PatchSizing::Count(2500), Backend::Auto).unwrap();
    let (reference, _) = solve(&world, &ReferenceOptions::default(), &NoProgress);
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
    d.converge(&world, 8);
    let p = &world.patches;
    let block = world
        .scene
        .objects
        .iter()
        .position(|o| o.name == "block")
        .unwrap();
    let top: Vec<usize> = p
        .range(block)
        .filter(|&i| p.normal[i].y > 0.9 && p.centre[i].y > BOX_AT.y)
        .collect();
    assert!(
        top.len() >= 9,
        "only {} patches on the block's top",
        top.len()
    );
    let error = error_over(&world, &top, d.radiosity(), &reference);
    println!("block top under the rider: {:.2} %", 100.0 * error);
    assert!(error < RIDER_TOP_BOUND, "block-top error {error}");
}
