//! The live engine: a program steers a scene without keyframes (moves an object with
//! transforms, switches a light) and gets the same light as the same motion written as
//! keyframes. The soak of random steering on every solver is `tests/soak.rs`.

use glam::{Affine3A, Vec3};
use shrad::dispersive::DispersiveOptions;
use shrad::engine::Engine;
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::PatchSizing;

use crate::common::steering::keyed_twin;

#[test]
fn steering_by_transforms_matches_the_same_keyframes() {
    const STEPS: usize = 6;
    let step = Vec3::new(-12.0, 0.0, 8.0);
    let warm = Vec3::new(17.0, 8.0, 2.0);
    let scene = shrad::scene::cornell_box();
    let choice = SolverChoice::Dispersive(DispersiveOptions::improved());
    let sizing = PatchSizing::Count(2500);
    let mut live = Engine::new(scene.clone(), sizing, Backend::Auto, choice).unwrap();
    let block = live.object("short_block").unwrap();
    let light = live.object("light").unwrap();
    let rest = live.transform(block);
    let keyed_scene = keyed_twin(scene, (block, light), (step, STEPS), (warm, 3.0));
    let mut keyed = Engine::new(keyed_scene, sizing, Backend::Auto, choice).unwrap();
    live.converge(2);
    keyed.converge(2);
    for k in 1..=STEPS {
        live.set_transform(block, Affine3A::from_translation(step * k as f32) * rest)
            .unwrap();
        if k == 3 {
            live.set_emission(light, warm).unwrap();
        }
        keyed.set_time(k as f32).unwrap();
        for _ in 0..2 {
            let a = live.step();
            let b = keyed.step();
            assert_eq!(a.objects_updated, b.objects_updated, "step {k}");
        }
        // The same light, patch by patch (float noise of the composed transforms only).
        let worst = live
            .radiosity()
            .iter()
            .zip(keyed.radiosity())
            .map(|(a, b)| (*a - *b).abs().max_element() / (1.0 + b.max_element()))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "step {k}: radiosity differs by {worst}");
    }
    let (a, b) = (live.error().overall, keyed.error().overall);
    assert!((a - b).abs() < 1e-4, "{a} vs {b}");
    assert!(a < 0.15, "error {a}");
}

/// `converge_by` steps the frames `converge` does (the same count, the same light), and an
/// error from its step ends the run at that frame (how a front end stops it: Python's
/// Ctrl-C).
#[test]
fn converge_by_steps_what_converge_does_and_stops_at_an_error() {
    let make = || {
        let choice = SolverChoice::Dispersive(DispersiveOptions::improved());
        let scene = shrad::scene::cornell_box();
        Engine::new(scene, PatchSizing::Count(1500), Backend::Auto, choice).unwrap()
    };
    let (mut a, mut b) = (make(), make());
    let want = a.converge(2);
    let got = b.converge_by(2, |e| Ok::<_, ()>(e.step())).unwrap();
    assert_eq!(want.len(), got.len());
    assert!(
        want.len() > b.frames_to_converge(2),
        "no settling frames to compare"
    );
    // The same light up to the float noise of parallel sums (rayon splits as it steals).
    let worst = (a.radiosity().iter().zip(b.radiosity()))
        .map(|(x, y)| (*x - *y).abs().max_element() / (1e-3 + y.max_element()))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "radiosity differs by {worst}");
    let mut c = make();
    let mut stepped = 0;
    let stop = c.converge_by(2, |e| {
        stepped += 1;
        let stats = e.step();
        if stepped == 3 {
            return Err("stop");
        }
        Ok(stats)
    });
    assert_eq!(stop.err(), Some("stop"));
    assert_eq!((stepped, c.frames()), (3, 3));
}

/// A transform is singular relative to its own scale, as a scene file's is judged: a block
/// shrunk to 1e-4 (determinant 1e-12) is a move (it was refused as singular), a flat one is
/// refused with its columns in the message (not Rust's debug text of the matrix).
#[test]
fn a_tiny_scale_is_a_move_and_a_flat_one_an_error_that_shows_it() {
    let scene = shrad::scene::cornell_box();
    let choice = SolverChoice::Dispersive(DispersiveOptions::improved());
    let mut e = Engine::new(scene, PatchSizing::Count(600), Backend::Auto, choice).unwrap();
    let block = e.object("short_block").unwrap();
    let rest = e.transform(block);
    let tiny = rest * Affine3A::from_scale(Vec3::splat(1e-4));
    e.set_transform(block, tiny).unwrap();
    let flat = rest * Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let message = e.set_transform(block, flat).unwrap_err().to_string();
    assert!(
        message.contains("singular")
            && message.contains("its columns: [[")
            && !message.contains("Affine3A"),
        "{message}"
    );
    // All but flat (one axis squashed by 1e-16: Embree aborted the process on the rays it
    // gave, the BVH gave NaN), or shrunk whole below the smallest size a scene loads at (NaN
    // too): refused, and the engine goes on where the block was.
    for (squash, what) in [
        (Vec3::new(1e-16, 1.0, 1.0), "singular, or all but"),
        (Vec3::splat(1e-20), "world size would be"),
    ] {
        let message = (e.set_transform(block, rest * Affine3A::from_scale(squash)))
            .unwrap_err()
            .to_string();
        assert!(message.contains(what), "{message}");
    }
    e.step();
    assert!(e.radiosity().iter().all(|b| b.is_finite()));
}

/// `converge` settles the grid too (it gathers one bounce a frame): in a closed box whose
/// every wall emits M = 1 and reflects 0.5, B = M / (1 - 0.5) = 2 everywhere (the white
/// furnace). At its two frames the grid stood at 1.75.
#[test]
fn converge_settles_the_grid_in_a_white_furnace() {
    use shrad::scene::{box_mesh, Material, Object, Role, Scene};
    let mut material = Material::diffuse(Vec3::splat(0.5));
    material.emitted_radiance = Vec3::splat(std::f32::consts::FRAC_1_PI);
    let mut room = Object::new("room", box_mesh(Vec3::splat(0.5), true), material);
    room.role = Some(Role::Boundary);
    let scene = Scene {
        source: "white furnace".into(),
        objects: vec![room],
        ..Default::default()
    };
    for solver in ["grid", "dispersive"] {
        let choice = SolverChoice::preset(solver, "default").unwrap();
        let mut e = Engine::new(
            scene.clone(),
            PatchSizing::Count(600),
            Backend::Auto,
            choice,
        )
        .unwrap();
        e.converge(2);
        let areas = &e.world().patches.area;
        let total: f32 = areas.iter().sum();
        let mean = (e.radiosity().iter().zip(areas))
            .map(|(b, a)| b.x * a)
            .sum::<f32>()
            / total;
        assert!(
            (mean - 2.0).abs() < 0.01,
            "{solver}: mean B {mean}, closed form 2"
        );
    }
}
