//! Meshes several of shrad's integration tests build the same way (each test binary uses
//! part of them), and the keyframed twin of a live-steered scene ([`steering`]).
#![allow(dead_code)]

pub mod steering;

use glam::Vec3;
use shrad_scene::{quad, Mesh};

/// A square of half-width `half` in y = 0 facing up (+y): a floor.
pub fn floor(half: f32) -> Mesh {
    let a = half;
    quad([
        Vec3::new(-a, 0.0, -a),
        Vec3::new(-a, 0.0, a),
        Vec3::new(a, 0.0, a),
        Vec3::new(a, 0.0, -a),
    ])
}

/// A unit square in y = 0 facing down (-y), counter-clockwise seen from below: a ceiling
/// light once moved up.
pub fn ceiling_light() -> Mesh {
    quad([
        Vec3::new(-0.5, 0.0, -0.5),
        Vec3::new(0.5, 0.0, -0.5),
        Vec3::new(0.5, 0.0, 0.5),
        Vec3::new(-0.5, 0.0, 0.5),
    ])
}

/// The largest difference of any patch's radiosity between `a` and `b`, and `b`'s largest
/// value.
pub fn largest_difference(a: &[Vec3], b: &[Vec3]) -> (f32, f32) {
    let worst = (a.iter().zip(b))
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max);
    let top = b.iter().map(|v| v.max_element()).fold(0.0, f32::max);
    (worst, top)
}
