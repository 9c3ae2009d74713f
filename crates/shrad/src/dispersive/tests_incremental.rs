//! Step 1's direct light and the wall exchange's rows are updated incrementally while an
//! occluder moves (only the rays that meet its old or new box are re-traced); after any
//! sequence of moves they must equal what a freshly built solver computes in the same world.

use glam::{Affine3A, Vec3};

use super::tests::{cornell, object_named};
use super::*;
use crate::direct::mover_spheres::OneMove;
use crate::direct::Moves;
use shrad_scene::Aabb;

/// The largest relative difference between two irradiance arrays (0 where both are 0).
fn max_relative(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs().max_element() / x.abs().max(y.abs()).max_element().max(1e-6))
        .fold(0.0, f32::max)
}

#[test]
fn moving_an_occluder_keeps_direct_light_and_wall_rows_exact() {
    let mut world = cornell(3000);
    let block = object_named(&world, "short_block");
    let rest = world.patches.world_from_local[block]
        * Affine3A::from_mat3(world.patches.local_from_object[block]);
    let options = DispersiveOptions::improved();
    assert!(options.wall_exchange && options.direct_on_interior);
    let mut d = Dispersive::new(&world, options).unwrap();
    d.step(&world, &Changes::default());
    // The rows kept with their rays are the shared form-factor rows.
    let plain = crate::form_factors::form_factor_rows(
        &world,
        &d.boundary_patches,
        options.wall_rays,
        &[],
        |j| receives_as_boundary(&world, j),
        &crate::NoProgress,
    )
    .unwrap();
    let kept = d.wall_rows.as_ref().unwrap().rows();
    assert!(plain
        .iter()
        .enumerate()
        .all(|(k, row)| kept.row(k) == &row[..]));
    let (start_rows, start_direct) = (
        d.wall_rows.as_ref().unwrap().rows().clone(),
        d.direct.clone(),
    );
    let mut rows_changed = 0;
    let mut direct_changed = 0;
    let size = world.scene.bounds().unwrap().size().x;
    // Small drags, a teleport across the room, a turn, and back home.
    let moves = [
        Affine3A::from_translation(Vec3::X * 0.02 * size) * rest,
        Affine3A::from_translation(Vec3::X * 0.04 * size) * rest,
        Affine3A::from_translation(Vec3::new(-0.3, 0.0, 0.2) * size) * rest,
        Affine3A::from_translation(Vec3::new(-0.3, 0.0, 0.2) * size)
            * rest
            * Affine3A::from_rotation_y(0.5),
        rest,
    ];
    for (step, m) in moves.into_iter().enumerate() {
        assert!(world.move_object(block, m).unwrap());
        d.step(
            &world,
            &Changes {
                moved: vec![block],
                relit: Vec::new(),
                ..Default::default()
            },
        );
        // The wall rays wait for later frames when there are more than a frame's share.
        let rows = d.wall_rows.as_ref().unwrap();
        let left = rows.dirty_rays();
        let mut frames = 0;
        let waiting = |d: &Dispersive| {
            let rows = d.wall_rows.as_ref().unwrap();
            rows.dirty_rays() > 0 || rows.unchecked_rows() > 0
        };
        while waiting(&d) {
            d.step(&world, &Changes::default());
            frames += 1;
            // An eighth of the rows checked and a 128th of the rays re-traced per frame.
            assert!(frames < 8 + 128 + 2, "wall rays left: {left}");
        }
        let mut fresh = Dispersive::new(&world, options).unwrap();
        fresh.step(&world, &Changes::default());
        let e = max_relative(&d.direct, &fresh.direct);
        assert!(e < 1e-5, "move {step}: direct light differs by {e}");
        let (a, b) = (
            d.wall_rows.as_ref().unwrap().rows(),
            fresh.wall_rows.as_ref().unwrap().rows(),
        );
        assert_eq!(a.len(), b.len());
        // Rows that differ only where a ray meets two surfaces at the same distance are the
        // same rows: the teleport puts the block partly into a side wall, and a ray from the
        // wall inside it meets its bottom face and the floor under it at one point; which of
        // the two a trace reports is arbitrary.
        let (ra, rb) = (
            d.wall_rows.as_ref().unwrap(),
            fresh.wall_rows.as_ref().unwrap(),
        );
        let differ = (0..a.len())
            .filter(|&k| a.row(k) != b.row(k) && !ra.differ_only_in_ties(rb, k))
            .count();
        assert_eq!(differ, 0, "move {step}: {differ} wall rows differ");
        let missing = ra.rows_missing_an_object_hit(&world);
        assert_eq!(
            missing, 0,
            "move {step}: {missing} rows' masks miss an object hit"
        );
        rows_changed += (0..a.len())
            .filter(|&k| a.row(k) != start_rows.row(k))
            .count();
        direct_changed += (0..d.direct.len())
            .filter(|&i| d.direct[i] != start_direct[i])
            .count();
    }
    // The caches stay small: about 10 bytes a wall ray (with the rows themselves, under 24),
    // and about 17 bytes a shadow ray (its blocked bit, its exact end and its weight)
    // plus tens of bytes a direct-light receiver.
    let rows = d.wall_rows.as_ref().unwrap();
    let rays = d.boundary_patches.len() * options.wall_rays as usize;
    assert!(
        rows.bytes() < 24 * rays,
        "{} bytes for {rays} rays",
        rows.bytes()
    );
    let shadow_rays = d.direct_cache.receivers().len() * options.direct_samples as usize;
    assert!(
        d.direct_cache.bytes() < 17 * shadow_rays + 64 * d.direct_cache.receivers().len(),
        "{} bytes for {shadow_rays} shadow rays",
        d.direct_cache.bytes()
    );
    // The moves changed what the walls see and the shadows: the test exercised something.
    assert!(
        rows_changed > 100 && direct_changed > 100,
        "{rows_changed} {direct_changed}"
    );
}

/// Move `block` of the Cornell box well away from its place; returns its world box before and
/// after.
fn move_far(world: &mut World, block: usize) -> (Aabb, Aabb) {
    let old = setup::world_box(world, block);
    let m = world.patches.world_from_local[block]
        * Affine3A::from_mat3(world.patches.local_from_object[block]);
    let far = Affine3A::from_translation(Vec3::new(8.0, 0.0, -10.0)) * m;
    world.move_object(block, far).unwrap();
    (old, setup::world_box(world, block))
}

/// The Cornell box at 2k patches, its tall block, its boundary patches and their direct-light
/// cache with 16 samples.
fn cornell_boundary_cache() -> (World, usize, Vec<u32>, crate::direct::DirectCache) {
    let world = cornell(2000);
    let block = object_named(&world, "tall_block");
    let boundary: Vec<u32> = (0..world.patches.len() as u32)
        .filter(|&i| world.patches.role(i as usize) == Role::Boundary)
        .collect();
    let cache = crate::direct::DirectCache::new(&world, boundary.clone(), 16);
    (world, block, boundary, cache)
}

/// A receiver that faces away from every emitter casts no shadow ray, and none is counted:
/// of the tall block's own patches only those that face the ceiling's light have rays (the
/// block's bottom and the sides turned away have none). Fails if the cache casts, or counts,
/// the empty rays of an unlit receiver (it did: a tenth of the 77k room's moving frame).
#[test]
fn a_receiver_facing_away_from_every_emitter_casts_no_shadow_ray() {
    let world = cornell(2000);
    let block = object_named(&world, "tall_block");
    let own: Vec<u32> = world.patches.range(block).map(|i| i as u32).collect();
    let before = world.rays_cast();
    let cache = crate::direct::DirectCache::new(&world, own, 16);
    let rays = world.rays_cast() - before;
    let (lit, sets) = cache.lit_sets();
    assert!(
        0 < lit && lit < sets,
        "{lit} of {sets} (receiver, emitter) pairs lit"
    );
    assert_eq!(rays, 16 * lit as u64, "{lit} lit pairs of 16 samples");
}

/// The built-in room of 8 objects at `patches` patches, and its ball (`sphere_2`).
fn room_and_its_ball(patches: usize) -> (World, usize) {
    let scene = shrad_scene::room(&shrad_scene::RoomParams {
        objects: 8,
        patches,
        big_object_patches: None,
    });
    let sizing = crate::PatchSizing::Count(patches);
    let world = World::new(scene, sizing, crate::vis::Backend::Auto).unwrap();
    let ball = object_named(&world, "sphere_2");
    (world, ball)
}

/// A moving ball's shadow rays are found by its boxes and by a sphere about it where it was
/// and where it is (`direct/mover_spheres.rs`): the update re-traces far fewer rays than by
/// its boxes alone (most rays through a ball's box pass beside the ball), and still equals
/// a fresh cache of the moved world. Fails if the spheres are not used (as many rays), or
/// if they drop a ray the move changed (the update then differs from the fresh cache).
#[test]
fn a_moving_balls_shadow_rays_are_found_by_its_spheres_and_stay_exact() {
    let (mut world, ball) = room_and_its_ball(8000);
    let boundary: Vec<u32> = (0..world.patches.len() as u32)
        .filter(|&i| world.patches.role(i as usize) == Role::Boundary)
        .collect();
    let mut cache = crate::direct::DirectCache::new(&world, boundary.clone(), 16);
    let mut boxes_only = cache.clone();
    let step = Vec3::X * 0.05 * world.scene.bounds().unwrap().size().x;
    let slide = OneMove::slide(&mut world, ball, step);
    let rays = |cache: &mut crate::direct::DirectCache, moves: Moves| {
        let before = world.rays_cast();
        let mover = [ball as u32];
        cache.update(&world, (&mover, &mover), moves, 16, 1);
        world.rays_cast() - before
    };
    let by_spheres = rays(&mut cache, slide.with_spheres());
    let by_boxes = rays(&mut boxes_only, slide.boxes_only());
    assert!(
        by_spheres * 5 < by_boxes * 4,
        "{by_spheres} rays re-traced with the spheres, {by_boxes} by the boxes alone"
    );
    let fresh = crate::direct::DirectCache::new(&world, boundary, 16);
    let off = |c: &crate::direct::DirectCache| {
        (c.irradiance().iter().zip(fresh.irradiance()))
            .filter(|(a, b)| a != b)
            .count()
    };
    assert_eq!(off(&cache), 0, "receivers off the fresh cache (spheres)");
    assert_eq!(off(&boxes_only), 0, "receivers off the fresh cache (boxes)");
}

/// The shadow rays' ends are kept exact, as the samples they were traced to, through set-up
/// and updates: a ray a mover may have changed is re-traced from its stored end (no sample
/// regenerated), so an end kept wrong would re-trace another ray than the cache holds.
#[test]
fn stored_shadow_ray_ends_are_the_samples_traced() {
    let (mut world, block, _, mut cache) = cornell_boundary_cache();
    let (checked, off) = cache.ends_off_their_samples(&world);
    assert!(checked > 10_000 && off == 0, "{off} of {checked} ends off");
    let (old, new) = move_far(&mut world, block);
    let mover = [block as u32];
    cache.update(
        &world,
        (&mover, &mover),
        Moves::boxes(&[old], &[new]),
        16,
        1,
    );
    let (checked, off) = cache.ends_off_their_samples(&world);
    assert!(
        checked > 10_000 && off == 0,
        "after a move: {off} of {checked} ends off"
    );
}

/// The cache's partial update equals a full recomputation with the same samples, also for
/// receivers given in another order (the samples depend on the patch and the emitter only).
#[test]
fn direct_cache_update_equals_a_full_recomputation() {
    let (mut world, block, boundary, mut cache) = cornell_boundary_cache();
    let (old, new) = move_far(&mut world, block);
    let changed = cache.update(
        &world,
        (&[block as u32], &[block as u32]),
        Moves::boxes(&[old], &[new]),
        16,
        1,
    );
    assert!(
        !changed.is_empty(),
        "moving the tall block changed no shadow"
    );
    let full = crate::direct::DirectCache::new(&world, boundary.clone(), 16);
    assert_eq!(cache.irradiance(), full.irradiance());
    let reversed: Vec<u32> = boundary.iter().rev().copied().collect();
    let mut back = crate::direct::direct_irradiance(&world, &reversed, 16);
    back.reverse();
    assert_eq!(back, full.irradiance());
}

/// The receivers of a direct-light test that watches one interior object: the boundary and
/// `block`'s own patches (as Step 1 has them with `direct_on_interior`).
fn boundary_and(world: &World, block: usize) -> Vec<u32> {
    let p = &world.patches;
    (0..p.len() as u32)
        .filter(|&i| p.role(i as usize) == Role::Boundary || p.object[i as usize] as usize == block)
        .collect()
}

/// A moving receiver traced with fewer samples is traced whole, with every sample, at the
/// first update where it rests: the cache then equals a fresh one.
#[test]
fn coarse_moving_receivers_are_exact_again_once_they_rest() {
    let mut world = cornell(2000);
    let block = object_named(&world, "tall_block");
    let receivers = boundary_and(&world, block);
    let mut cache = crate::direct::DirectCache::new(&world, receivers.clone(), 16);
    let (old, new) = move_far(&mut world, block);
    let mut every_sample = cache.clone();
    let rays = |cache: &mut crate::direct::DirectCache, samples: u32| {
        let before = world.rays_cast();
        cache.update(
            &world,
            (&[block as u32], &[block as u32]),
            Moves::boxes(&[old], &[new]),
            samples,
            4,
        );
        world.rays_cast() - before
    };
    let (coarse, fine) = (rays(&mut cache, 4), rays(&mut every_sample, 16));
    assert!(
        cache.has_coarse() && !every_sample.has_coarse(),
        "the block's patches were not traced coarse"
    );
    assert!(coarse < fine, "coarse {coarse} rays, every sample {fine}");
    let full = crate::direct::DirectCache::new(&world, receivers.clone(), 16);
    // At rest: nothing moves, and the coarse receivers are traced whole again.
    let changed = cache.update(&world, (&[], &[]), Moves::boxes(&[], &[]), 16, 1);
    assert!(!changed.is_empty() && !cache.has_coarse());
    assert_eq!(cache.irradiance(), full.irradiance());
}

/// A moving block's receivers not traced in an update are held (their exact unoccluded
/// light where they are now, under their last trace's visible fraction) only when the update
/// reads them (Step 2 lights the block that frame); unread, they keep what they had, and the
/// update that reads them gives what holding them at every update gives. Fails if an unread
/// receiver is held anyway, or if a read update misses receivers skipped before.
#[test]
fn a_movers_held_light_is_held_only_when_read_and_then_equals_holding_every_update() {
    let mut world = cornell(2000);
    let block = object_named(&world, "tall_block");
    let receivers = boundary_and(&world, block);
    let own: Vec<usize> = (0..receivers.len())
        .filter(|&k| world.patches.object[receivers[k] as usize] as usize == block)
        .collect();
    let mut every = crate::direct::DirectCache::new(&world, receivers, 16);
    let mut when_read = every.clone();
    let start = world.patches.world_from_local[block]
        * Affine3A::from_mat3(world.patches.local_from_object[block]);
    let b = [block as u32];
    for step in 1..=4 {
        let old = setup::world_box(&world, block);
        let at = Affine3A::from_translation(Vec3::new(0.3 * step as f32, 0.0, 0.0)) * start;
        world.move_object(block, at).unwrap();
        let new = setup::world_box(&world, block);
        let before = when_read.irradiance().to_vec();
        let read: &[u32] = if step == 4 { &b } else { &[] };
        every.update(&world, (&b, &b), Moves::boxes(&[old], &[new]), 4, 4);
        let changed = when_read.update(&world, (&b, read), Moves::boxes(&[old], &[new]), 4, 4);
        if step == 1 || step == 4 {
            // The first update holds every untraced receiver, read or not (they were exact
            // until then); the fourth reads them all.
            assert_eq!(when_read.irradiance(), every.irradiance(), "update {step}");
            continue;
        }
        // One in 4 is traced each update; the others were coarse already and are not read.
        let kept: Vec<usize> = (own.iter().copied())
            .filter(|&k| changed.binary_search(&k).is_err())
            .collect();
        let untraced: Vec<usize> = (own.iter().copied())
            .filter(|&k| k % 4 != (step - 1) % 4)
            .collect();
        assert_eq!(kept, untraced, "update {step}");
        assert!(kept.iter().all(|&k| when_read.irradiance()[k] == before[k]));
        assert!(
            (kept.iter()).any(|&k| when_read.irradiance()[k] != every.irradiance()[k]),
            "update {step}: holding changed nothing, the test exercises nothing"
        );
    }
}

/// A large mover's coarse receivers are traced again with every sample
/// [`crate::direct::SETTLED_AT_ONCE`] an update once it rests, and are exact when all are:
/// fails if the ones left for later are forgotten (they would keep their coarse light).
#[test]
fn a_large_movers_coarse_receivers_settle_over_several_updates_to_the_exact_light() {
    let mut world = cornell(12_000);
    let block = object_named(&world, "tall_block");
    let receivers = boundary_and(&world, block);
    let own = world.patches.range(block).len();
    assert!(own > crate::direct::SETTLED_AT_ONCE, "{own} patches");
    let mut cache = crate::direct::DirectCache::new(&world, receivers.clone(), 16);
    let (old, new) = move_far(&mut world, block);
    cache.update(
        &world,
        (&[block as u32], &[block as u32]),
        Moves::boxes(&[old], &[new]),
        4,
        1,
    );
    assert!(cache.has_coarse());
    let full = crate::direct::DirectCache::new(&world, receivers, 16);
    let mut updates = 0;
    while cache.has_coarse() {
        let changed = cache.update(&world, (&[], &[]), Moves::boxes(&[], &[]), 16, 1);
        assert!(changed.len() <= crate::direct::SETTLED_AT_ONCE);
        updates += 1;
        assert!(updates <= 100, "the coarse receivers never settle");
    }
    assert_eq!(updates, own.div_ceil(crate::direct::SETTLED_AT_ONCE));
    assert_eq!(cache.irradiance(), full.irradiance());
}

/// While a block moves and receivers take turns, one in 4 has its shadow rays found per
/// update, against every move since its last turn: at its turn a receiver's light is what a
/// full recomputation gives there and then, and every receiver is exact again at the first
/// update after the block rests. Fails if a turn forgets an earlier move's boxes (a receiver
/// would keep a shadow the block has left) or if the rest does not catch up.
#[test]
fn shadow_receivers_found_in_turn_are_exact_at_their_turn_and_at_rest() {
    let (mut world, block, boundary, mut cache) = cornell_boundary_cache();
    // Turns whatever the count (the Cornell box at 2k patches changes far fewer rays than
    // `SHADOW_RAYS_AT_ONCE`).
    cache.take_turns_above(0);
    let start = world.patches.world_from_local[block]
        * Affine3A::from_mat3(world.patches.local_from_object[block]);
    let mut lagging = 0;
    for step in 1..=6 {
        let old = setup::world_box(&world, block);
        let at = Affine3A::from_translation(Vec3::new(0.5 * step as f32, 0.0, 0.0)) * start;
        world.move_object(block, at).unwrap();
        let new = setup::world_box(&world, block);
        // Fewer samples for moving receivers: the in-turn finding is on (stride 4).
        cache.update(
            &world,
            (&[block as u32], &[block as u32]),
            Moves::boxes(&[old], &[new]),
            4,
            4,
        );
        let full = crate::direct::DirectCache::new(&world, boundary.clone(), 16);
        let phase = (step - 1) % 4;
        for k in 0..boundary.len() {
            let (got, want) = (cache.irradiance()[k], full.irradiance()[k]);
            if k % 4 == phase {
                assert_eq!(got, want, "receiver {k} at its turn, update {step}");
            } else if got != want {
                lagging += 1;
            }
        }
    }
    assert!(
        lagging > 0,
        "no receiver lagged: the test exercised nothing"
    );
    assert!(cache.catching_up());
    let changed = cache.update(&world, (&[], &[]), Moves::boxes(&[], &[]), 16, 1);
    assert!(!changed.is_empty() && !cache.catching_up());
    let full = crate::direct::DirectCache::new(&world, boundary, 16);
    assert_eq!(cache.irradiance(), full.irradiance());
}

/// While an object moves, Step 4 and the energy meter visit only the chunks of patches the
/// frame touched (`touched.rs`): after every moving frame the boundary's radiosity is what a
/// pass over every boundary patch gives, exactly, and the meter's sums are a full balance's.
/// Fails if a writer of the irradiance arrays forgets to mark what it wrote.
#[test]
fn a_moving_frame_assembles_and_meters_only_what_it_touched_and_misses_nothing() {
    // A room large enough for a moving frame to leave chunks untouched (the wall window
    // alone covers 8k boundary patches a frame).
    let room = shrad_scene::room(&shrad_scene::RoomParams {
        objects: 4,
        patches: 40_000,
        big_object_patches: None,
    });
    let mut world = World::new(
        room,
        crate::PatchSizing::Count(40_000),
        crate::vis::Backend::Auto,
    )
    .unwrap();
    let p = &world.patches;
    let block = (0..p.object_role.len())
        .filter(|&o| p.object_role[o] == Role::Interior)
        .max_by_key(|&o| p.range(o).len())
        .unwrap();
    let rest = world.patches.world_from_local[block]
        * Affine3A::from_mat3(world.patches.local_from_object[block]);
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
    d.converge(&world, 2);
    let size = world.scene.bounds().unwrap().size().x;
    let mut skipped = 0;
    for step in 1..=12 {
        let m = Affine3A::from_translation(Vec3::X * 0.01 * size * step as f32) * rest;
        assert!(world.move_object(block, m).unwrap());
        let moved = Changes {
            moved: vec![block],
            ..Default::default()
        };
        let stats = d.step(&world, &moved);
        let p = &world.patches;
        for &j in d.boundary_patches.iter() {
            let j = j as usize;
            let full = world.exitance[j]
                + world.reflectance[j] * (d.direct[j] + d.indirect[j] + d.wall[j]);
            assert_eq!(d.radiosity[j], full, "patch {j}, frame {step}");
        }
        // The meter: a fresh balance of the same state.
        let metered = d.light_meter.measure(&d.radiosity);
        let irradiance = |i: usize| match p.role(i) {
            Role::Interior => d.probe_irradiance[i] + d.direct[i],
            Role::Light if !metered.is_empty() => metered
                .binary_search_by_key(&(i as u32), |&(j, _)| j)
                .map_or(d.direct[i] + d.indirect[i] + d.wall[i], |k| metered[k].1),
            _ => d.direct[i] + d.indirect[i] + d.wall[i],
        };
        let fresh = crate::energy::balance(&world, irradiance, d.punctual_irradiance(), |i| {
            p.role(i) != Role::Light || receives_as_boundary(&world, i)
        });
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
        let e = stats.energy;
        assert!(
            close(e.received, fresh.received)
                && close(e.reflected, fresh.reflected)
                && close(e.absorbed, fresh.absorbed)
                && close(e.emitted, fresh.emitted),
            "frame {step}: {e:?} against {fresh:?}"
        );
        // And it did skip chunks (the test exercises the partial passes).
        skipped += d.energy_chunks.len() - d.chunks_metered;
    }
    assert!(skipped > 0, "every moving frame touched every chunk");
}

/// While another object moves, a still object's update sends the boundary only the light
/// paths the mover crossed (`resend.rs`): the amended contribution equals a splat of the same
/// light traced afresh, with nothing cached. Fails if the flux is not taken off the patches
/// it went to, or not put where it lands now.
#[test]
fn a_still_objects_amended_splat_equals_a_fresh_full_splat() {
    amended_contribution_equals_a_fresh_one(ToBoundary::Splat, true);
}

/// The same with the gather: the entries whose shadow ray the mover crossed are traced again
/// and their light, as sent, taken off or put on. One emitter at the centre, so that no
/// softening rescales the whole contribution (a factor over every entry clear, which an
/// amendment keeps as it was sent: with an emitter per face the fresh gather differs from
/// the amended one by up to 2.4 % of the brightest patch here).
#[test]
fn a_still_objects_amended_gather_equals_a_fresh_full_gather() {
    amended_contribution_equals_a_fresh_one(ToBoundary::Gather, false);
}

/// The Cornell box converged with contributions amended within 0.5, the tall block's sent
/// afresh, then the short block moved across the light it sends the walls (not yet
/// updated): the world, the solver, the tall block's index in it, and the indirect light
/// before the move.
fn still_block_crossed_by_a_mover(
    to_boundary: ToBoundary,
    emitter_per_face: bool,
) -> (World, Dispersive, usize, Vec<Vec3>) {
    let mut world = cornell(3000);
    let mover = object_named(&world, "short_block");
    let still = object_named(&world, "tall_block");
    let options = DispersiveOptions {
        to_boundary,
        resend_tolerance: 0.5,
        sleep_tolerance: 0.0,
        emitter_per_face,
        ..DispersiveOptions::improved()
    };
    let mut d = Dispersive::new(&world, options).unwrap();
    d.converge(&world, 20);
    let k = d.objects.iter().position(|ob| ob.object == still).unwrap();
    d.objects_to_boundary(&world, vec![k], (0.0, None));
    let before = d.indirect.clone();
    slide_and_check(&mut world, &mut d, mover, k, Vec3::new(0.1, 0.0, 0.15));
    (world, d, k, before)
}

fn amended_contribution_equals_a_fresh_one(to_boundary: ToBoundary, emitter_per_face: bool) {
    let (world, mut d, k, before) = still_block_crossed_by_a_mover(to_boundary, emitter_per_face);
    assert!(
        d.resend_crossed_paths(&world, k, 0.5, None).is_some(),
        "the still block's contribution was not amended"
    );
    let amended = d.indirect.clone();
    d.objects[k].emitter_cache = caches::EmitterCache::default();
    d.objects_to_boundary(&world, vec![k], (0.0, None));
    let scale = before.iter().map(|e| e.max_element()).fold(0.0, f32::max);
    let differ = |a: &[Vec3], b: &[Vec3], by: f32| {
        a.iter()
            .zip(b)
            .filter(|(x, y)| (**x - **y).abs().max_element() > by * scale)
            .count()
    };
    assert!(
        differ(&before, &amended, 1e-3) > 10,
        "the mover crossed none of the still block's light paths: the test exercised nothing"
    );
    assert_eq!(differ(&amended, &d.indirect, 1e-5), 0);
}

/// Step 3's amendment found beside Step 1 (`Dispersive::crossed_ahead`) leaves the boundary
/// as Step 3 finding it itself does: when Step 3 reads it, when Step 3 does not light the
/// object (the change is sent anyway: the texels it moved are no longer listed), and when
/// the object's light changed more than the tolerance and is sent whole instead. Fails if
/// the change found ahead is dropped, sent twice, or if the texels it traced leave the whole
/// send different.
#[test]
fn crossed_paths_found_ahead_leave_the_boundary_as_step3_finding_them() {
    for (to_boundary, per_face) in [(ToBoundary::Splat, true), (ToBoundary::Gather, false)] {
        let run = |ahead: bool, lit: bool, brighter: f32| -> Vec<Vec3> {
            let (world, mut d, k, _) = still_block_crossed_by_a_mover(to_boundary, per_face);
            let still = d.objects[k].object;
            let ahead = ahead.then(|| d.crossed_ahead(&world, k, 0.5));
            assert!(
                ahead.as_ref().is_none_or(Option::is_some),
                "nothing found ahead"
            );
            // Its light since it was sent: the same, or `brighter` times it.
            for i in world.patches.range(still) {
                d.radiosity[i] *= brighter;
            }
            let lit = if lit { vec![k] } else { Vec::new() };
            d.objects_to_boundary(&world, lit, (0.5, ahead.flatten()));
            d.indirect.clone()
        };
        let amended = run(false, true, 1.0);
        assert_eq!(run(true, true, 1.0), amended, "read by Step 3");
        assert_eq!(run(true, false, 1.0), amended, "not read by Step 3");
        assert_ne!(
            run(false, false, 1.0),
            amended,
            "the mover crossed no light path"
        );
        let whole = run(false, true, 2.0);
        assert_ne!(whole, amended, "a light twice as bright was not sent whole");
        assert_eq!(
            run(true, true, 2.0),
            whole,
            "sent whole after its paths were found"
        );
    }
}

/// Amending still objects' contributions while another moves (`resend.rs`) leaves no trace
/// once the scene rests: after a block moves for 12 frames and then stays, the light
/// converges to what sending everything at every update gives. Fails if a contribution
/// amended while moving is never sent whole again at rest.
#[test]
fn amended_contributions_converge_to_the_same_light_at_rest() {
    for to_boundary in [ToBoundary::Splat, ToBoundary::Gather] {
        amended_contributions_converge(to_boundary);
    }
}

fn amended_contributions_converge(to_boundary: ToBoundary) {
    let runs: Vec<Vec<Vec3>> = [0.5, 0.0]
        .into_iter()
        .map(|resend_tolerance| {
            let mut world = cornell(3000);
            let mover = object_named(&world, "short_block");
            let options = DispersiveOptions {
                to_boundary,
                resend_tolerance,
                sleep_tolerance: 0.0,
                ..DispersiveOptions::improved()
            };
            let mut d = Dispersive::new(&world, options).unwrap();
            d.converge(&world, 20);
            drag(&mut world, &mut d, mover, 12, Vec3::new(0.02, 0.0, 0.01));
            d.converge(&world, 40);
            d.radiosity().to_vec()
        })
        .collect();
    let scale = runs[1].iter().map(|e| e.max_element()).fold(0.0, f32::max);
    let worst = runs[0]
        .iter()
        .zip(&runs[1])
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0, f32::max);
    assert!(
        worst <= 1e-4 * scale,
        "{to_boundary:?}: differ by {worst} of {scale}"
    );
}

/// A neighbour's move forgets a still object's near field only at the patches it comes
/// within reach of (`stale.rs`), and measuring those again gives what measuring them all
/// gives. Fails if a patch the move changed is left out.
#[test]
fn a_near_field_measured_again_in_part_equals_one_measured_whole() {
    let mut world = cornell(3000);
    let mover = object_named(&world, "short_block");
    let still = object_named(&world, "tall_block");
    // A reach at which the slide below leaves most of the tall block's patches out of it
    // (at the default's 0.35 more than half are within it, and then all are forgotten).
    let options = DispersiveOptions {
        sleep_tolerance: 0.0,
        near_reach: 0.25,
        ..DispersiveOptions::improved()
    };
    let mut d = Dispersive::new(&world, options).unwrap();
    d.converge(&world, 4);
    let k = d.objects.iter().position(|ob| ob.object == still).unwrap();
    let mut steps = DispersiveStats::default();
    assert!(d.prepare_update(&world, k, None, &mut steps));
    assert!(d.objects[k].openness_current && !d.objects[k].near.lobe.is_empty());
    // The short block slides towards the tall one.
    slide_and_check(&mut world, &mut d, mover, k, Vec3::new(-0.08, 0.0, 0.06));
    let (stale, patches) = (
        d.objects[k].near_stale.len(),
        world.patches.range(still).len(),
    );
    assert!(
        stale > 0 && stale * 2 <= patches,
        "{stale} of {patches} stale"
    );
    assert!(d.prepare_update(&world, k, None, &mut steps));
    let near = &d.objects[k].near;
    let part = (near.lobe.clone(), near.measured_rows());
    d.objects[k].forget_openness();
    assert!(d.prepare_update(&world, k, None, &mut steps));
    let near = &d.objects[k].near;
    assert!(part.0 == near.lobe, "the lobes differ");
    assert!(part.1 == near.measured_rows(), "the rows differ");
}

/// When an object stops, the objects near it are updated before it: their light and what
/// they send the walls still carry its path, and its own full update first made the error
/// rise until they caught up (issue 22 item 3, `examples/stability.rs`).
#[test]
fn the_neighbours_of_an_object_that_stops_are_updated_before_it() {
    let mut world = cornell(3000);
    let mover = object_named(&world, "short_block");
    let neighbour = object_named(&world, "tall_block");
    let options = DispersiveOptions {
        sleep_tolerance: 0.0,
        ..DispersiveOptions::improved()
    };
    let mut d = Dispersive::new(&world, options).unwrap();
    d.converge(&world, 4);
    drag(&mut world, &mut d, mover, 6, Vec3::X * 0.01);
    let first = d.step(&world, &Changes::default());
    let second = d.step(&world, &Changes::default());
    assert_eq!(
        (first.objects_updated, second.objects_updated),
        (vec![neighbour], vec![mover])
    );
}

/// A moving ball's swept boxes are logged with a sphere about it where it was and where it
/// is (`stale.rs`, `direct/mover_spheres.rs`), so the caches of the objects around it forget
/// only the rays that meet the ball there, not all that meet its boxes, and Step 1 is given
/// them with its move (`DirectSync`) for its shadow rays: a drag re-traces fewer rays than
/// with the boxes alone, and gives the same light. Fails if the spheres are
/// not used (as many rays), or if they leave a changed ray cached (the light differs).
#[test]
fn a_balls_swept_spheres_forget_fewer_cached_rays_and_give_the_same_light() {
    let (mut world, ball) = room_and_its_ball(6000);
    let options = DispersiveOptions {
        sleep_tolerance: 0.0,
        ..DispersiveOptions::improved()
    };
    let mut spheres = Dispersive::new(&world, options).unwrap();
    let mut boxes = Dispersive::new(&world, options).unwrap();
    boxes.object_spheres.iter_mut().for_each(|s| *s = None);
    boxes.direct_sync.spheres.iter_mut().for_each(|s| *s = None);
    spheres.converge(&world, 3);
    boxes.converge(&world, 3);
    let start = world.patches.world_from_local[ball]
        * Affine3A::from_mat3(world.patches.local_from_object[ball]);
    let size = world.scene.bounds().unwrap().size().x;
    let (mut by_spheres, mut by_boxes) = (0, 0);
    for f in 1..=8 {
        let m = Affine3A::from_translation(Vec3::X * 0.01 * f as f32 * size) * start;
        world.move_object(ball, m).unwrap();
        let changes = Changes {
            moved: vec![ball],
            ..Default::default()
        };
        let before = world.rays_cast();
        spheres.step(&world, &changes);
        let between = world.rays_cast();
        boxes.step(&world, &changes);
        (by_spheres, by_boxes) = (
            by_spheres + between - before,
            by_boxes + world.rays_cast() - between,
        );
        let off = max_relative(spheres.radiosity(), boxes.radiosity());
        assert!(off < 1e-5, "frame {f}: the light differs by {off}");
    }
    assert!(
        by_spheres < by_boxes,
        "{by_spheres} rays with the spheres, {by_boxes} with the boxes alone"
    );
}

/// Move `mover` `frames` times by `step` (in room widths) from where it is, a frame each.
pub(super) fn drag(world: &mut World, d: &mut Dispersive, mover: usize, frames: usize, step: Vec3) {
    let start = world.patches.world_from_local[mover]
        * Affine3A::from_mat3(world.patches.local_from_object[mover]);
    let size = world.scene.bounds().unwrap().size().x;
    for f in 1..=frames {
        let m = Affine3A::from_translation(step * f as f32 * size) * start;
        world.move_object(mover, m).unwrap();
        let changes = Changes {
            moved: vec![mover],
            ..Default::default()
        };
        d.step(world, &changes);
    }
}

/// Slide `mover` by `offset` (in room widths) from where it rests, in one move, and let
/// object `k`'s caches see it (the stale test), as a frame would before updating `k`.
fn slide_and_check(world: &mut World, d: &mut Dispersive, mover: usize, k: usize, offset: Vec3) {
    let rest = world.patches.world_from_local[mover]
        * Affine3A::from_mat3(world.patches.local_from_object[mover]);
    let size = world.scene.bounds().unwrap().size().x;
    let to = Affine3A::from_translation(offset * size) * rest;
    assert!(world.move_object(mover, to).unwrap());
    let changes = Changes {
        moved: vec![mover],
        ..Default::default()
    };
    d.note_changes(world, &changes);
    let swept = d.swept_boxes(world, &changes);
    d.log_swept(world, &changes, &swept);
    d.forget_stale_caches(world, &[k]);
}
