//! The live engine: a program steers a scene without keyframes (moves an object with
//! transforms, switches a light) and gets the same light as the same motion written as
//! keyframes; and a soak of random steering on every solver and preset stays finite, within
//! the energy bound, and flat in memory.

use glam::{Affine3A, Quat, Vec3};
use shrad::dispersive::DispersiveOptions;
use shrad::engine::Engine;
use shrad::grid::GridOptions;
use shrad::scene::{Animation, EmissionKey, Keyframe};
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::PatchSizing;

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
    let mut keyed_scene = scene;
    keyed_scene.objects[block].animation = Some(Animation {
        keys: (0..=STEPS)
            .map(|k| Keyframe {
                time: k as f32,
                translation: step * k as f32,
                rotation: Quat::IDENTITY,
            })
            .collect(),
        step: true,
        ..Default::default()
    });
    let base = keyed_scene.objects[light].material.emitted_radiance;
    keyed_scene.objects[light].animation = Some(Animation {
        emission: vec![
            EmissionKey {
                time: 0.0,
                emitted_radiance: base,
            },
            EmissionKey {
                time: 3.0,
                emitted_radiance: warm,
            },
        ],
        step: true,
        ..Default::default()
    });
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

/// Resident memory of this process (bytes), from /proc/self/statm.
fn rss() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: u64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    pages * 4096
}

/// Random motion and light changes, `frames` frames on every solver and preset; the full
/// size (10,000 frames each) runs with `SHRAD_SOAK_FRAMES=10000 cargo test --release -p shrad
/// --test engine soak -- --nocapture`.
#[test]
fn soak_random_steering_on_every_solver() {
    let frames: usize = std::env::var("SHRAD_SOAK_FRAMES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1500);
    let choices = [
        (
            "default",
            SolverChoice::Dispersive(DispersiveOptions::improved()),
        ),
        (
            "paper",
            SolverChoice::Dispersive(DispersiveOptions {
                cube_res: 16,
                emitter_res: 16,
                ..DispersiveOptions::paper()
            }),
        ),
        (
            "grid",
            SolverChoice::Grid(GridOptions {
                cube_res: 8,
                ..GridOptions::paper(3)
            }),
        ),
    ];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        ((state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
    };
    for (name, choice) in choices {
        let mut engine = Engine::new(
            shrad::scene::cornell_box(),
            PatchSizing::Count(400),
            Backend::Auto,
            choice,
        )
        .unwrap();
        let blocks = [
            engine.object("short_block").unwrap(),
            engine.object("tall_block").unwrap(),
        ];
        let light = engine.object("light").unwrap();
        let rests = blocks.map(|o| engine.transform(o));
        let (mut worst, mut rss_after_100) = (0.0f64, 0u64);
        let mut rss_max = 0u64;
        for f in 0..frames {
            let k = (rand() * 2.0) as usize % 2;
            let offset = Vec3::new(rand() - 0.5, 0.0, rand() - 0.5) * 200.0;
            let turn = Quat::from_rotation_y(rand() * std::f32::consts::TAU);
            let rest = rests[k];
            let centre = rest.translation;
            let at = Affine3A::from_translation(Vec3::from(centre) + offset)
                * Affine3A::from_quat(turn)
                * Affine3A::from_translation(-Vec3::from(centre))
                * rest;
            engine.set_transform(blocks[k], at).unwrap();
            if f % 7 == 0 {
                let c = Vec3::new(rand(), rand(), rand()) * 30.0;
                engine.set_emission(light, c).unwrap();
            }
            let stats = engine.step();
            let e = stats.energy;
            assert!(
                e.reflected <= e.reflected_bound * shrad::energy::BOUND_TOLERANCE + 1e-9,
                "{name} frame {f}: {e:?}"
            );
            assert!(
                engine.radiosity().iter().all(|b| b.is_finite()),
                "{name} frame {f}: non-finite radiosity"
            );
            worst = worst.max(e.bound_ratio());
            if f == 100 {
                rss_after_100 = rss();
            }
            if f > 100 {
                rss_max = rss_max.max(rss());
            }
        }
        let growth = rss_max as f64 / rss_after_100.max(1) as f64 - 1.0;
        eprintln!(
            "soak {name}: {frames} frames, largest reflected / bound {worst:.3}, memory {:.1} MiB after 100 frames, growth after that {:.2} %",
            rss_after_100 as f64 / (1 << 20) as f64,
            100.0 * growth
        );
        assert!(
            growth < 0.05,
            "{name}: memory grew by {:.1} %",
            100.0 * growth
        );
    }
}
