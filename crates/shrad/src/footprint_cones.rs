//! Which of a receiver's rays may meet a mover, from their directions alone: the rays start
//! anywhere on the receiver's footprint and go anywhere in its hemisphere (the sky's rays,
//! [`crate::sky::SkyCache`]), so no bound on where they go rejects a receiver; but a ray
//! that meets a sphere goes in a direction within the cone from the footprint's centre to
//! that sphere grown by the footprint's radius. Each ray's direction is kept in 4 bytes
//! ([`encode`], octahedral), and testing it against the cone replaces regenerating the ray
//! (an importance-sampled direction, a point on the patch) and a slab test: the 77k room
//! under a uniform sky, its largest object moving, 49.5 -> 18.7 ms a frame, the same rays.

use glam::{Vec2, Vec3};

/// The angle (radians) the cones are widened by: more than [`encode`]'s error and the
/// rounding of the cone's own floats.
const MARGIN: f32 = 2e-3;

/// A unit direction in 4 bytes: the octahedral map (Meyer et al. 2010), 16 bits an axis.
/// [`decode`] gives it back within 1e-4 radians.
pub(crate) fn encode(d: Vec3) -> [u16; 2] {
    let d = d / (d.x.abs() + d.y.abs() + d.z.abs()).max(f32::MIN_POSITIVE);
    let xy = match d.z >= 0.0 {
        true => Vec2::new(d.x, d.y),
        false => fold(Vec2::new(d.x, d.y)),
    };
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65535.0).round() as u16;
    [q(xy.x), q(xy.y)]
}

/// The unit direction [`encode`] kept (the tests' reading; the sky tests 64 at a time:
/// [`FootprintCones::meeting`]).
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn decode([a, b]: [u16; 2]) -> Vec3 {
    let xy = Vec2::new(a as f32, b as f32) / 65535.0 * 2.0 - 1.0;
    let z = 1.0 - xy.x.abs() - xy.y.abs();
    let xy = match z >= 0.0 {
        true => xy,
        false => fold(xy),
    };
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// The octahedron's lower half folded over its upper (and back: it is its own inverse).
fn fold(v: Vec2) -> Vec2 {
    Vec2::new(
        (1.0 - v.y.abs()) * 1f32.copysign(v.x),
        (1.0 - v.x.abs()) * 1f32.copysign(v.y),
    )
}

/// Spheres a set may hold for [`FootprintCones`] (more: no cones, every ray is a candidate).
const MOST: usize = 8;

/// The cones of directions in which a ray from a footprint (a sphere: centre and radius)
/// may meet one of two sets of spheres (at most [`MOST`] a set).
pub(crate) struct FootprintCones {
    /// Per set, per sphere: the cone's axis (unit) and the cosine of its half-angle (below
    /// -1 where the footprint is within reach of the sphere: every direction).
    cones: [[(Vec3, f32); MOST]; 2],
    /// Spheres per set.
    len: [usize; 2],
}

impl FootprintCones {
    /// The cones from the footprint `(c, r)` to each sphere of `sets`; `None` when a set
    /// holds more than [`MOST`].
    pub(crate) fn new((c, r): (Vec3, f32), sets: [&[(Vec3, f32)]; 2]) -> Option<FootprintCones> {
        let cone = |&(b, br): &(Vec3, f32)| {
            let (to, reach) = (b - c, br + r);
            let dist = to.length();
            if dist <= reach * (1.0 + 1e-4) {
                return (Vec3::Z, -2.0);
            }
            // At most a right angle and the margin: its cosine is the test's as it is.
            (to / dist, ((reach / dist).asin() + MARGIN).cos())
        };
        let mut out = FootprintCones {
            cones: [[(Vec3::Z, -2.0); MOST]; 2],
            len: sets.map(<[_]>::len),
        };
        for (cones, set) in out.cones.iter_mut().zip(sets) {
            if set.len() > MOST {
                return None;
            }
            for (c, s) in cones.iter_mut().zip(set) {
                *c = cone(s);
            }
        }
        Some(out)
    }

    /// Whether a ray in direction `d` (unit, within [`MARGIN`]) from the footprint may meet
    /// a sphere of set `s` (one at a time, as the tests check [`FootprintCones::meeting`]).
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn may_meet(&self, s: usize, d: Vec3) -> bool {
        self.cones[s][..self.len[s]]
            .iter()
            .any(|&(axis, cos)| d.dot(axis) >= cos)
    }

    /// Of up to 64 rays with directions `kept` ([`encode`]d), bit `j` set where ray `j` may
    /// meet a sphere of set 1, or of set 0 where bit `j` of `in_set_0` is set: the test of
    /// [`FootprintCones::may_meet`] on the directions as kept, without normalising them
    /// (`d . a >= cos |d|` squared), lane by lane over arrays the compiler vectorises.
    pub(crate) fn meeting(&self, kept: &[[u16; 2]], in_set_0: u64) -> u64 {
        const LANES: usize = 64;
        let n = kept.len().min(LANES);
        let (mut x, mut y, mut z) = ([0f32; LANES], [0f32; LANES], [0f32; LANES]);
        for (j, &[a, b]) in kept[..n].iter().enumerate() {
            let (u, v) = (
                a as f32 / 65535.0 * 2.0 - 1.0,
                b as f32 / 65535.0 * 2.0 - 1.0,
            );
            let w = 1.0 - u.abs() - v.abs();
            let folded = w < 0.0;
            x[j] = if folded {
                (1.0 - v.abs()) * 1f32.copysign(u)
            } else {
                u
            };
            y[j] = if folded {
                (1.0 - u.abs()) * 1f32.copysign(v)
            } else {
                v
            };
            z[j] = w;
        }
        let mut masks = [0u64; 2];
        for (s, mask) in masks.iter_mut().enumerate() {
            let mut met = [false; LANES];
            for &(a, cos) in &self.cones[s][..self.len[s]] {
                let c2 = cos * cos;
                for j in 0..LANES {
                    let t = x[j] * a.x + y[j] * a.y + z[j] * a.z;
                    let l2 = x[j] * x[j] + y[j] * y[j] + z[j] * z[j];
                    let within = match cos >= 0.0 {
                        true => t >= 0.0 && t * t >= c2 * l2,
                        false => t >= 0.0 || t * t <= c2 * l2,
                    };
                    met[j] |= within;
                }
            }
            *mask = (0..n).fold(0, |m, j| m | u64::from(met[j]) << j);
        }
        (masks[0] & in_set_0) | (masks[1] & !in_set_0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shrad_scene::Aabb;

    #[test]
    fn a_direction_comes_back_within_a_ten_thousandth_of_a_radian() {
        let mut rnd = crate::sampling::test_rng(5);
        let mut worst = 0f32;
        for case in 0..20000 {
            let mut d = Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0;
            // The axes and the octahedron's edges among them.
            match case % 5 {
                0 => d[case % 3] = 0.0,
                1 => d = Vec3::ZERO.with_x(1.0 - 2.0 * (case % 2) as f32),
                _ => {}
            }
            let d = d.normalize_or(Vec3::Z);
            let back = decode(encode(d));
            // The angle from its sine and cosine (an arc cosine near 1 loses it in f32).
            worst = worst.max(back.cross(d).length().atan2(back.dot(d)));
        }
        assert!(worst < 1e-4, "{worst} radians");
    }

    /// Every segment from a point of the footprint that meets a box has its direction (as
    /// kept) in one of the cones to the boxes' spheres; most that pass far do not.
    #[test]
    fn the_cones_hold_every_ray_that_meets_a_box() {
        let mut rnd = crate::sampling::test_rng(9);
        let (mut met, mut rejected) = (0, 0);
        for case in 0..400 {
            let mut v = |s: f32| (Vec3::new(rnd(), rnd(), rnd()) * 2.0 - 1.0) * s;
            let (c, r) = (v(2.0), 0.02 + 0.3 * (case % 4) as f32);
            let h = v(0.4).abs() + 0.05;
            let centre = v(2.0);
            let boxes = [Aabb::new(centre - h, centre + h)];
            let spheres: Vec<(Vec3, f32)> = boxes.iter().map(Aabb::bounding_sphere).collect();
            let cones = FootprintCones::new((c, r), [&spheres, &[]]).unwrap();
            let mut kept = Vec::new();
            for _ in 0..200 {
                let from = c + v(1.0).clamp_length_max(r);
                let d = v(1.0).normalize_or(Vec3::X);
                kept.push(encode(d));
                let back = decode(encode(d));
                let meets = boxes[0].meets_segment(from, from + d * 100.0);
                // The lanes' test as the one-at-a-time one, in set 0 and in set 1 (empty).
                let lanes = |set_0: u64| cones.meeting(&kept[kept.len() - 1..], set_0) & 1 != 0;
                assert!(
                    !lanes(0) && !cones.may_meet(1, back),
                    "an empty set meets nothing"
                );
                match meets {
                    true => {
                        assert!(
                            cones.may_meet(0, back),
                            "case {case}: a ray that meets the box"
                        );
                        assert!(
                            lanes(1),
                            "case {case}: the lanes miss a ray that meets the box"
                        );
                        met += 1;
                    }
                    false => rejected += usize::from(!cones.may_meet(0, back) && !lanes(1)),
                }
            }
            // 64 at a time as one at a time, but where the two roundings differ at a cone's
            // edge (within its margin).
            let first: Vec<[u16; 2]> = kept[..64].to_vec();
            let bits = cones.meeting(&first, u64::MAX);
            let one =
                (0..64).filter(|&j| cones.may_meet(0, decode(first[j])) != (bits >> j & 1 != 0));
            assert!(one.count() <= 1, "case {case}");
        }
        assert!(
            met > 1000 && rejected > 20000,
            "{met} met, {rejected} rejected"
        );
    }
}
