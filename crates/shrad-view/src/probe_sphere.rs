//! The probe spheres the page draws: each probe's irradiance is sent at the vertices of a
//! unit sphere made from an octahedron (the `probes` message).

use glam::Vec3;
use serde_json::{json, Value};
use shrad::engine::Engine;
use shrad::view_data;

use crate::protocol;

/// Unit directions of the probe spheres (an octahedron split twice, normalised): each
/// probe's irradiance is sent at these.
pub const SPLITS: u32 = 2;

/// The `probes` message of frame `frame`: each probe of the engine's solver with its
/// irradiance at `directions` (`solver` names it when it has no per-object probes).
pub fn message(engine: &Engine, directions: &[Vec3], frame: u64, solver: &str) -> String {
    let Some(probes) = view_data::probes(engine) else {
        return protocol::message(
            "probes",
            json!({ "frame": frame, "probes": [], "note": format!("the {solver} solver has no per-object probes") }),
        );
    };
    let list: Vec<Value> = probes
        .iter()
        .map(|q| {
            let irradiance: Vec<f32> = directions
                .iter()
                .flat_map(|&d| {
                    // As the radiance of a white diffuse surface facing `d`.
                    (shrad_sh::irradiance(&q.sh, d) * std::f32::consts::FRAC_1_PI)
                        .max(Vec3::ZERO)
                        .to_array()
                })
                .collect();
            json!({
                "object": q.object,
                "corner": q.corner,
                "position": q.position.to_array(),
                "state": q.state,
                "radiance": irradiance,
            })
        })
        .collect();
    protocol::message("probes", json!({ "frame": frame, "probes": list }))
}

/// A unit sphere: an octahedron whose faces are split `splits` times (each split makes four
/// triangles of one), its vertices pushed onto the sphere.
pub fn probe_sphere(splits: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut v = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let mut t: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    for _ in 0..splits {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::with_capacity(4 * t.len());
        let mut middle = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        for [a, b, c] in t {
            let ab = middle(a, b, &mut v);
            let bc = middle(b, c, &mut v);
            let ca = middle(c, a, &mut v);
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        t = next;
    }
    (v, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_closed_unit_sphere_facing_outward() {
        for splits in 0..=3u32 {
            let (v, t) = probe_sphere(splits);
            // Each split makes four triangles of one; a closed triangulated sphere has
            // V = 2 + F / 2 (Euler, with E = 3F / 2).
            let faces = 8 * 4usize.pow(splits);
            assert_eq!(t.len(), faces);
            assert_eq!(v.len(), 2 + faces / 2);
            assert!(v.iter().all(|d| (d.length() - 1.0).abs() < 1e-6));
            for [a, b, c] in t {
                let (a, b, c) = (v[a as usize], v[b as usize], v[c as usize]);
                assert!(
                    (b - a).cross(c - a).dot(a + b + c) > 0.0,
                    "a face looks inward"
                );
            }
        }
    }
}
