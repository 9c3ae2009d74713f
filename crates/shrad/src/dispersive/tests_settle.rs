//! Settling after a mover stops (`sleep.rs`): the objects settle one at a time, Step 3
//! amends what it sent while their light changes by less than the sleep tolerance, the
//! walls doze (a small window of rows) while the light they read changes by less than it,
//! and the scene falls asleep with every wall row gathered from its rows as they are now.

use glam::{Affine3A, Vec3};

use super::*;
use crate::vis::Backend;
use crate::PatchSizing;

/// The built-in room at 16k patches (more boundary rows than a dozing window holds), its
/// largest object slid along x a frame a step as the bench does, then left until the scene
/// sleeps; with how many frames the walls dozed meanwhile.
fn room_settled_after_a_slide() -> (World, Dispersive, usize) {
    let scene = shrad_scene::room(&shrad_scene::RoomParams {
        objects: 8,
        patches: 16_000,
        big_object_patches: None,
    });
    let mut world = World::new(scene, PatchSizing::Count(16_000), Backend::Auto).unwrap();
    let p = &world.patches;
    let mover = (0..p.object_role.len())
        .filter(|&o| p.object_role[o] == shrad_scene::Role::Interior)
        .max_by_key(|&o| p.range(o).len())
        .unwrap();
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
    assert!(d.boundary_patches.len() > 2 * WALL_ROWS_DOZING);
    d.converge(&world, 3);
    let rest = world.patches.world_from_local[mover]
        * Affine3A::from_mat3(world.patches.local_from_object[mover]);
    let size = world.scene.bounds().unwrap().size().x;
    for f in 1..=8 {
        let to = Affine3A::from_translation(Vec3::X * 0.04 * f as f32 * size) * rest;
        assert!(world.move_object(mover, to).unwrap());
        let moved = Changes {
            moved: vec![mover],
            ..Default::default()
        };
        d.step(&world, &moved);
    }
    let still = Changes::default();
    let mut dozed = 0;
    for _ in 0..2000 {
        dozed += usize::from(d.walls_doze(&still));
        if d.step(&world, &still).dispersive().unwrap().asleep {
            return (world, d, dozed);
        }
    }
    panic!("the scene never fell asleep after the object stopped");
}

/// Row `k`'s wall-exchange gather from the radiosity as it is now, and what Step 4 holds
/// for it (before the neighbourhood smoothing when that is on).
fn gather_now_and_held(world: &World, d: &Dispersive, k: usize) -> (Vec3, Vec3) {
    let rows = d.wall_rows.as_ref().unwrap();
    let fresh = (rows.row(k).iter())
        .map(|&(i, f)| (d.radiosity[i as usize] - world.exitance[i as usize]) * f)
        .sum();
    let j = d.boundary_patches[k] as usize;
    let held = match d.options.wall_smoothing {
        true => d.wall_gathered[j],
        false => d.wall[j],
    };
    (fresh, held)
}

#[test]
fn a_scene_that_settles_dozes_and_sleeps_with_every_wall_row_gathered_as_it_is() {
    let (world, d, dozed) = room_settled_after_a_slide();
    assert!(dozed > 0, "the walls never dozed: this tests nothing");
    // Every row gathered again would give what Step 4 holds, to within the sleep
    // tolerance's reach.
    let (mut worst, mut largest) = (0f32, 0f32);
    for k in 0..d.boundary_patches.len() {
        let (fresh, held) = gather_now_and_held(&world, &d, k);
        worst = worst.max((fresh - held).abs().max_element());
        largest = largest.max(fresh.max_element());
    }
    assert!(
        worst <= 1e-3 * largest,
        "a wall row's gather is {worst} off what its row gives now (largest {largest})"
    );
}

#[test]
fn a_row_rebuilt_while_the_walls_doze_is_gathered_beside_their_window() {
    let (world, mut d, _) = room_settled_after_a_slide();
    // A row the dozing window will not reach this frame, its gather spoiled, its rays' hits
    // forgotten: the re-trace rebuilds it, as after a mover's passage.
    let n = d.boundary_patches.len();
    let k = (d.wall_cursor + n / 2) % n;
    let j = d.boundary_patches[k] as usize;
    let (fresh, _) = gather_now_and_held(&world, &d, k);
    assert!(fresh.max_element() > 0.0);
    d.wall_gathered[j] = Vec3::ZERO;
    d.wall[j] = Vec3::ZERO;
    d.wall_rows.as_mut().unwrap().forget_hits(k);
    let still = Changes::default();
    assert!(
        d.walls_doze(&still),
        "the walls of a sleeping scene should doze"
    );
    let s = d.step(&world, &still);
    assert!(
        !s.dispersive().unwrap().asleep,
        "a dirty row let the scene sleep"
    );
    assert_eq!(d.wall_rows.as_ref().unwrap().dirty_rays(), 0);
    let (fresh, held) = gather_now_and_held(&world, &d, k);
    assert!(
        (fresh - held).abs().max_element() <= 1e-4 * fresh.max_element(),
        "the re-traced row holds {held} where it gives {fresh}"
    );
}

/// A ball rolled along the floor: its lower probes, sunk into the floor at the corners, are
/// moved up when it starts to move and stay where they were found valid while it moves (each
/// captured once an update, not once at the corner and again moved); once it rests, its full
/// update puts them where a fresh solver of that place does.
#[test]
fn a_movers_repaired_probes_stay_repaired_while_it_moves_and_return_at_rest() {
    let scene = shrad_scene::room(&shrad_scene::RoomParams {
        objects: 3,
        patches: 6000,
        big_object_patches: None,
    });
    let mut world = World::new(scene, PatchSizing::Count(6000), Backend::Auto).unwrap();
    let ball = (world.scene.objects.iter())
        .position(|o| o.name == "sphere_2")
        .unwrap();
    let mut d = Dispersive::new(&world, DispersiveOptions::default()).unwrap();
    d.converge(&world, 2);
    let k = (d.objects.iter()).position(|ob| ob.object == ball).unwrap();
    let rest = world.patches.world_from_local[ball]
        * Affine3A::from_mat3(world.patches.local_from_object[ball]);
    let size = world.scene.bounds().unwrap().size().x;
    // (captured, invalid) at each of the ball's updates while it rolls.
    let mut updates = Vec::new();
    for f in 1..=24 {
        let m = Affine3A::from_translation(Vec3::X * 0.004 * size * f as f32) * rest;
        world.move_object(ball, m).unwrap();
        let changes = Changes {
            moved: vec![ball],
            ..Default::default()
        };
        let stats = d.step(&world, &changes);
        let steps = stats.dispersive().unwrap();
        if stats.objects_updated.contains(&ball) {
            updates.push((steps.probes_captured, steps.probes_invalid));
        }
    }
    assert!(updates.len() >= 3, "{updates:?}");
    assert!(
        updates[0].1 > 0,
        "its first update finds probes in the floor: {updates:?}"
    );
    for &(captured, invalid) in &updates[1..] {
        assert_eq!((captured, invalid), (8, 0), "{updates:?}");
    }
    assert!(d.objects[k]
        .probe_scale
        .iter()
        .any(|s| s.min_element() < 1.0));
    // Lifted off the floor and left there: the probes go back to the corners (valid there
    // now), as a fresh solver of that place has them.
    let lifted = Affine3A::from_translation(Vec3::Y * 0.05 * size)
        * world.patches.world_from_local[ball]
        * Affine3A::from_mat3(world.patches.local_from_object[ball]);
    world.move_object(ball, lifted).unwrap();
    let changes = Changes {
        moved: vec![ball],
        ..Default::default()
    };
    d.step(&world, &changes);
    d.step(&world, &Changes::default());
    d.converge(&world, 2);
    let mut fresh = Dispersive::new(&world, DispersiveOptions::default()).unwrap();
    fresh.converge(&world, 2);
    assert_eq!(d.objects[k].probe_scale, fresh.objects[k].probe_scale);
}
