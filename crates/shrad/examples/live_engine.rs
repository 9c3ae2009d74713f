//! Drive the engine live, without keyframes (issue 11's check): load the Cornell box, move
//! the short block along the floor in 10 transform steps, switch the light's colour half way,
//! and after each step print the frame time and the error against a reference solve of that
//! state. Then the same motion written as keyframes, for comparison.
//!
//! `cargo run --release --example live_engine [patches] [frames_per_step]`
use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::PatchSizing;

// The keyframed twin, shared with the test of this check (tests/engine.rs).
#[path = "../tests/common/steering.rs"]
mod steering;

use steering::keyed_twin;

const STEPS: usize = 10;

fn main() {
    let mut args = std::env::args().skip(1);
    let patches: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(8000);
    let per_step: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(4);
    let step = Vec3::new(-12.0, 0.0, 8.0); // along the floor
    let warm = Vec3::new(17.0, 8.0, 2.0);

    // Live: transforms and emission set by the program.
    let scene = shrad::scene::cornell_box();
    let choice = SolverChoice::Dispersive(Default::default());
    let mut live = Engine::new(
        scene.clone(),
        PatchSizing::Count(patches),
        Backend::Auto,
        choice,
    )
    .expect("engine");
    let block = live.object("short_block").unwrap();
    let light = live.object("light").unwrap();
    let rest = live.transform(block);
    live.converge(4);
    println!("step  frame ms  error % (live)  error % (keyframes)");
    // Keyframed: the same motion as keys, played with set_time.
    let keyed_scene = keyed_twin(
        scene,
        (block, light),
        (step, STEPS),
        (warm, (STEPS / 2) as f32),
    );
    let mut keyed = Engine::new(
        keyed_scene,
        PatchSizing::Count(patches),
        Backend::Auto,
        choice,
    )
    .expect("engine");
    keyed.converge(4);
    for k in 1..=STEPS {
        live.set_transform(block, Affine3A::from_translation(step * k as f32) * rest)
            .unwrap();
        if k == STEPS / 2 {
            live.set_emission(light, warm).unwrap();
        }
        keyed.set_time(k as f32).unwrap();
        let mut ms = 0.0;
        for _ in 0..per_step {
            ms += live.step().frame_ms;
            keyed.step();
        }
        println!(
            "{k:>4}  {:>8.2}  {:>14.2}  {:>19.2}",
            ms / per_step as f64,
            100.0 * live.error().overall,
            100.0 * keyed.error().overall
        );
    }
}
