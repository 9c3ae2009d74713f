//! The keyframed twin of a program that steers an engine live: the same motion and light
//! switch written as step keys, so that `tests/engine.rs` and `examples/live_engine.rs`
//! can play it beside the live engine and compare.

use glam::{Quat, Vec3};
use shrad::scene::{Animation, EmissionKey, Keyframe, Scene};

/// `scene` with object `block` moved by `step` at every whole time 1..=`steps` (keys held
/// until the next) and object `light`'s emission switched to `warm` at time `warm_at`.
pub fn keyed_twin(
    mut scene: Scene,
    (block, light): (usize, usize),
    (step, steps): (Vec3, usize),
    (warm, warm_at): (Vec3, f32),
) -> Scene {
    scene.objects[block].animation = Some(Animation {
        keys: (0..=steps)
            .map(|k| Keyframe {
                time: k as f32,
                translation: step * k as f32,
                rotation: Quat::IDENTITY,
            })
            .collect(),
        step: true,
        ..Default::default()
    });
    let base = scene.objects[light].material.emitted_radiance;
    scene.objects[light].animation = Some(Animation {
        emission: vec![
            EmissionKey {
                time: 0.0,
                emitted_radiance: base,
            },
            EmissionKey {
                time: warm_at,
                emitted_radiance: warm,
            },
        ],
        step: true,
        ..Default::default()
    });
    scene
}
