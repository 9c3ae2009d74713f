//! An object's update prepared over several frames under a budget (`prepare.rs`): the light
//! is the same as an update that measures everything in one go, and an object that may not
//! wait longer gets a coarse update without losing what was prepared.

use std::time::Instant;

use glam::Vec3;

use super::tests::{cornell, object_named};
use super::tests_incremental::drag;
use super::*;

/// The Cornell box with the short block dragged for a few frames and then at rest (its light
/// from coarse updates, its geometry to measure again), under a budget schedule whose
/// staleness bound is `max_staleness`; the block's index among the interior objects.
fn stopped_block(to_boundary: ToBoundary, max_staleness: usize) -> (World, Dispersive, usize) {
    let mut world = cornell(3000);
    let mover = object_named(&world, "short_block");
    let options = DispersiveOptions {
        to_boundary,
        sleep_tolerance: 0.0,
        ..DispersiveOptions::improved()
    };
    let mut d = Dispersive::new(&world, options).unwrap();
    d.converge(&world, 4);
    drag(&mut world, &mut d, mover, 4, Vec3::X * 0.02);
    d.set_schedule(Schedule::Budget {
        ms: 1e6,
        max_staleness,
    })
    .unwrap();
    // The first frame at rest: it stops (`note_changes`), nothing else happens.
    d.note_changes(&world, &Changes::default());
    let k = d.objects.iter().position(|ob| ob.object == mover).unwrap();
    assert!(d.objects[k].coarse_light && !d.objects[k].openness_current);
    (world, d, k)
}

/// Update object `k` alone (Steps 2 and 3) with `deadline`; whether it was lit, and the
/// rays it cast.
fn update(world: &World, d: &mut Dispersive, k: usize, deadline: Option<Instant>) -> (bool, u64) {
    let mut stats = FrameStats::new(d.frame, SolverStats::Dispersive(Default::default()));
    let mut steps = DispersiveStats::default();
    let rays = world.rays_cast();
    let lit = d.light_selected_objects(
        world,
        (Batch(vec![k]), FirstObject::NotLit),
        &mut stats,
        &mut steps,
        deadline,
    );
    let updated = !lit.is_empty();
    d.objects_to_boundary(world, lit, (0.0, None));
    (updated, world.rays_cast() - rays)
}

/// The block's full update prepared a chunk at a time (a deadline that has always passed:
/// one chunk a call) gives the light of the same update measured whole, with the splat and
/// with the gather. Fails if a prepared probe or emitter ray is not what the update would
/// have traced, or if the update traces again what was prepared.
#[test]
fn an_update_prepared_in_pieces_equals_one_measured_whole() {
    for to_boundary in [ToBoundary::Splat, ToBoundary::Gather] {
        let (world, mut pieces, k) = stopped_block(to_boundary, 1000);
        let (_, mut whole, _) = stopped_block(to_boundary, 1000);
        let mut calls = 0;
        let rays_of_update = loop {
            match update(&world, &mut pieces, k, Some(Instant::now())) {
                (true, rays) => break rays,
                _ => calls += 1,
            }
            assert!(calls < 1000, "{to_boundary:?}: the preparation never ends");
        };
        // Its near field, 8 probes and emitters: more than one piece each.
        assert!(
            calls > 10,
            "{to_boundary:?}: prepared in {calls} pieces only"
        );
        assert!(!pieces.objects[k].coarse_light);
        let (lit, rays_whole) = update(&world, &mut whole, k, None);
        assert!(lit);
        // The update read what was prepared: it traced (almost) nothing itself.
        assert!(
            rays_of_update * 100 < rays_whole,
            "{to_boundary:?}: {rays_of_update} rays after the preparation, {rays_whole} whole"
        );
        let scale = whole
            .radiosity
            .iter()
            .map(|b| b.max_element())
            .fold(0.0, f32::max);
        for (name, a, b) in [
            ("radiosity", &pieces.radiosity, &whole.radiosity),
            ("indirect", &pieces.indirect, &whole.indirect),
        ] {
            let worst = a
                .iter()
                .zip(b)
                .map(|(x, y)| (*x - *y).abs().max_element())
                .fold(0.0, f32::max);
            assert!(
                worst <= 1e-6 * scale,
                "{to_boundary:?}: {name} differs by {worst} of {scale}"
            );
        }
    }
}

/// An object whose full update is being prepared and that reaches the staleness bound gets a
/// coarse update, as while it moved (its light stays coarse), with one more piece prepared,
/// and the preparation goes on from where it was to a full update. Fails if the bound forces
/// the whole preparation into one frame, or if the coarse update throws away what was
/// prepared.
#[test]
fn an_object_over_the_staleness_bound_before_it_is_prepared_gets_a_coarse_update() {
    let (world, mut d, k) = stopped_block(ToBoundary::Splat, 1000);
    // Its near field, and then its first probes, a piece a call.
    let probes = |d: &Dispersive| d.objects[k].probe_cache.probes.iter().flatten().count();
    while probes(&d) < 2 {
        assert!(!update(&world, &mut d, k, Some(Instant::now())).0);
    }
    assert!(d.objects[k].openness_current);
    // Over the bound: it goes now, coarse.
    let prepared = probes(&d);
    d.set_schedule(Schedule::Budget {
        ms: 1e6,
        max_staleness: 1,
    })
    .unwrap();
    assert!(update(&world, &mut d, k, Some(Instant::now())).0);
    assert!(
        d.objects[k].coarse_light,
        "the forced update was a full one"
    );
    // It prepared one more piece, and kept what was prepared.
    assert_eq!(probes(&d), prepared + 1, "the prepared probes were dropped");
    // Within the bound again: the preparation goes on, and the full update follows.
    d.set_schedule(Schedule::Budget {
        ms: 1e6,
        max_staleness: 1000,
    })
    .unwrap();
    let mut calls = 0;
    while !update(&world, &mut d, k, Some(Instant::now())).0 {
        calls += 1;
        assert!(calls < 1000, "the preparation never ends");
    }
    assert!(!d.objects[k].coarse_light);
    assert!(probes(&d) == 8 && calls >= 7 - prepared);
}
