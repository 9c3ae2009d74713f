//! The solid cores: which meshes have one, how big, and that a shadow ray among movers
//! settled by a core is what the backend's trace gives.

use glam::{Affine3A, Quat, Vec3};
use shrad_scene::{box_mesh, room, Mesh, RoomParams, Scene};
use shrad_vis::Backend;

use super::*;
use crate::patches::PatchSizing;
use crate::World;

fn core_of(mesh: &Mesh) -> Option<SolidCore> {
    SolidCore::of_mesh(&mesh.positions, &mesh.triangles)
}

#[test]
fn a_box_has_a_core_that_nearly_fills_it() {
    let half = Vec3::new(1.0, 0.5, 2.0);
    let core = core_of(&box_mesh(half, false)).expect("a closed box has a core");
    let (radius, core_half) = core.size();
    assert!((radius - MARGIN * 0.5).abs() < 1e-4, "radius {radius}");
    // The box's half size to within the bisection's step.
    assert!(
        (core_half - MARGIN * half).abs().max_element() < 2e-3 * half.max_element(),
        "{core_half}"
    );
    // Its faces' normals do not matter (a room's walls face in).
    assert!(core_of(&box_mesh(half, true)).is_some());
}

#[test]
fn an_open_or_hollow_mesh_has_none() {
    let mut open = box_mesh(Vec3::ONE, false);
    open.triangles.truncate(10);
    assert_eq!(core_of(&open), None, "a box without one face");
    // A shell: a box within a box, facing in; its centre is in the hollow, outside the
    // solid (an even number of crossings).
    let mut shell = box_mesh(Vec3::splat(2.0), false);
    let inner = box_mesh(Vec3::ONE, true);
    let n = shell.positions.len() as u32;
    shell.positions.extend(&inner.positions);
    (shell.triangles).extend(inner.triangles.iter().map(|t| t.map(|i| i + n)));
    assert_eq!(core_of(&shell), None, "a hollow shell");
    assert_eq!(core_of(&Mesh::default()), None, "no triangles");
    let mut broken = box_mesh(Vec3::ONE, false);
    broken.triangles[0][1] = 99;
    assert_eq!(core_of(&broken), None, "a corner out of range");
}

/// Random points in the box `lo..hi`, from a fixed seed.
fn points(n: usize, lo: Vec3, hi: Vec3, seed: u64) -> Vec<Vec3> {
    let mut s = seed;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| lo + (hi - lo) * Vec3::new(next(), next(), next()))
        .collect()
}

/// `occluded_among` the object `o` alone (cores first) against the backend's own trace of
/// the same segments with every other object left out: the same answers, and fewer rays
/// cast. Returns the share of segments the core settled.
fn cores_agree_with_the_trace(world: &World, o: usize, from: &[Vec3], to: &[Vec3]) -> f64 {
    let others: Vec<u32> = (0..world.vis.object_count() as u32)
        .filter(|&x| x != o as u32)
        .collect();
    let mut traced = vec![false; from.len()];
    let mut cored = vec![false; from.len()];
    world
        .vis
        .occluded(from, to, world.eps, &others, &mut traced);
    let before = world.rays_cast();
    (world.vis).occluded_among(from, to, world.eps, &[o as u32], &mut cored);
    let cast = world.rays_cast() - before;
    let differ = (0..from.len()).filter(|&r| traced[r] != cored[r]).count();
    assert_eq!(differ, 0, "of {} segments", from.len());
    1.0 - cast as f64 / from.len() as f64
}

/// Segments from the floor to the ceiling of the room (its walls are 8 x 3 x 6, from the
/// origin), through the box about object `o`.
fn segments_past(world: &World, o: usize) -> (Vec<Vec3>, Vec<Vec3>) {
    let b =
        shrad_scene::Aabb::from_points((world.patches.range(o)).map(|i| world.patches.centre[i]))
            .unwrap();
    let pad = 0.3 * b.size();
    let from = points(4000, b.min - pad, b.max + pad, 7)
        .into_iter()
        .map(|p| Vec3::new(p.x, 0.001, p.z))
        .collect();
    let to = points(4000, b.min - pad, b.max + pad, 11)
        .into_iter()
        .map(|p| Vec3::new(p.x, 2.999, p.z))
        .collect();
    (from, to)
}

#[test]
fn the_rooms_movers_settle_rays_as_the_trace_does() {
    let mut scene: Scene = room(&RoomParams {
        objects: 4,
        patches: 6000,
        big_object_patches: None,
    });
    // Turned, mirrored and stretched: the core goes where the object goes.
    let interior: Vec<usize> = (scene.objects.iter().enumerate())
        .filter(|(_, o)| o.role == Some(shrad_scene::Role::Interior))
        .map(|(k, _)| k)
        .collect();
    let last = *interior.last().unwrap();
    let m = &mut scene.objects[last].world_from_object;
    *m *= Affine3A::from_scale_rotation_translation(
        Vec3::new(-1.3, 0.8, 1.1),
        Quat::from_rotation_y(0.7),
        Vec3::ZERO,
    );
    let mut world = World::new(scene, PatchSizing::Count(6000), Backend::Auto).unwrap();
    for &o in &interior {
        let (from, to) = segments_past(&world, o);
        let settled = cores_agree_with_the_trace(&world, o, &from, &to);
        assert!(
            settled > 0.1,
            "object {o}: {settled:.3} settled by its core"
        );
    }
    // Moved (as a mover is), the core follows.
    let o = interior[0];
    let xf =
        Affine3A::from_translation(Vec3::new(0.4, 0.0, -0.3)) * world.patches.world_from_local[o];
    world.patches.set_transform(o, xf);
    world.vis.set_transform(o, xf);
    world.vis.commit();
    let (from, to) = segments_past(&world, o);
    assert!(cores_agree_with_the_trace(&world, o, &from, &to) > 0.1);
}

#[test]
fn a_segment_that_ends_inside_an_objects_box_is_traced() {
    let world = World::new(
        room(&RoomParams {
            objects: 1,
            patches: 3000,
            big_object_patches: None,
        }),
        PatchSizing::Count(3000),
        Backend::Auto,
    )
    .unwrap();
    let o = world.vis.object_count() - 1;
    let c: Vec3 = world
        .patches
        .range(o)
        .map(|i| world.patches.centre[i])
        .sum::<Vec3>()
        / world.patches.range(o).len() as f32;
    // From the object's centre (inside it) up to the ceiling: one crossing, blocked, but the
    // core cannot say so (an end inside the box): the backend is asked.
    let before = world.rays_cast();
    let mut out = [false];
    let up = Vec3::new(c.x, 2.999, c.z);
    (world.vis).occluded_among(&[c], &[up], world.eps, &[o as u32], &mut out);
    assert_eq!(world.rays_cast() - before, 1);
    assert!(out[0]);
}

#[test]
fn a_collapsed_or_broken_transform_leaves_no_core() {
    let mesh = box_mesh(Vec3::ONE, false);
    let meshes = [(&mesh.positions[..], &mesh.triangles[..])];
    let mut cores = SolidCores::new(&meshes, &[Affine3A::IDENTITY], |_| true);
    let (from, to) = (Vec3::new(-5.0, 0.1, 0.2), Vec3::new(5.0, -0.1, 0.0));
    assert!(
        cores.blocks(&[0], from, to, 1e-4),
        "through the unit box's core"
    );
    assert!(
        !cores.blocks(&[0], from, to + Vec3::Y * 20.0, 1e-4),
        "past it"
    );
    for broken in [
        Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        Affine3A::from_translation(Vec3::splat(f32::NAN)),
    ] {
        cores.place(0, broken);
        assert!(!cores.blocks(&[0], from, to, 1e-4), "{broken:?}");
    }
    // An object not picked, or out of range, has none.
    let none = SolidCores::new(&meshes, &[Affine3A::IDENTITY], |_| false);
    assert!(!none.blocks(&[0, 7], from, to, 1e-4));
}
