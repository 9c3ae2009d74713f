//! Rejecting whole blocks of a [`super::DirectCache`]'s receivers at once: a mover far from
//! every shadow ray of a block (consecutive receivers, near one another) cannot change any.

use glam::Vec3;

use crate::World;

/// Receivers per block of [`DirectCache`]'s rejection test (consecutive receivers are
/// patches of one object, near one another). At the 77k room with its largest object moving,
/// 7.7k receivers are left for the per-receiver cone test with blocks of 16, 25k with 64.
pub(crate) const BLOCK: usize = 16;

/// Blocks per group: a group's sphere holds its blocks' spheres, so that a mover far from a
/// group rejects its 256 receivers with one test (the 77k room's 4.8k blocks each took one
/// per emitter and swept box, though a tenth of them pass).
pub(crate) const GROUP: usize = 16;

/// A sphere: centre and radius.
pub type Sphere = (Vec3, f32);

/// After `receivers` `ks` (indices, ascending) moved: the spheres of the blocks holding them,
/// `sphere` of each block's receivers where they are now, and of those blocks' groups.
pub(crate) fn refresh(
    (blocks, groups): (&mut [Sphere], &mut [Sphere]),
    (receivers, ks): (&[u32], &[usize]),
    sphere: impl Fn(&[u32]) -> Sphere,
) {
    let mut moved: Vec<usize> = ks.iter().map(|&k| k / BLOCK).collect();
    moved.dedup();
    for &b in &moved {
        blocks[b] = sphere(&receivers[b * BLOCK..((b + 1) * BLOCK).min(receivers.len())]);
    }
    let mut gs: Vec<usize> = moved.iter().map(|&b| b / GROUP).collect();
    gs.dedup();
    for g in gs {
        groups[g] = group_sphere(&blocks[g * GROUP..((g + 1) * GROUP).min(blocks.len())]);
    }
}

/// A sphere holding the spheres `blocks`.
pub(crate) fn group_sphere(blocks: &[(Vec3, f32)]) -> (Vec3, f32) {
    let (lo, hi) = (blocks.iter()).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), &(c, r)| {
        (a.min(c - r), b.max(c + r))
    });
    let c = 0.5 * (lo + hi);
    let r = (blocks.iter()).fold(0.0f32, |m, &(q, r)| m.max((q - c).length() + r));
    (c, r * (1.0 + 1e-6))
}

/// Bounding sphere of the centres of `receivers` (padded by the shadow rays' offset).
pub(super) fn block_sphere(world: &World, receivers: &[u32]) -> (Vec3, f32) {
    let p = &world.patches;
    let pts = receivers.iter().map(|&i| p.centre[i as usize]);
    let (lo, hi) = pts
        .clone()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), c| {
            (a.min(c), b.max(c))
        });
    let c = 0.5 * (lo + hi);
    let r = pts.map(|q| (q - c).length()).fold(0.0, f32::max);
    (c, r + 2.0 * world.eps)
}

/// Whether a shadow ray from anywhere in the sphere `(oc, or)` to anywhere in the sphere
/// `(lc, lr)` may meet the sphere `(bc, br)`. The ray's point at `s` in [0, 1] is
/// `(1 - s) y0 + s y1` with `y0` within `or` of `oc` and `y1` within `lr` of `lc`: within
/// `(1 - s) or + s lr` of the axis point `a(s) = oc + s (lc - oc)`. So it may meet the sphere
/// when `|bc - a(s)| - (1 - s) or - s lr <= br` for some `s`; the left side is convex in
/// `s`, and its minimum is found as in [`super::cone_meets_sphere`] (a tapered capsule: near a
/// block of receivers it is as thin as the block, not as wide as the light).
pub(super) fn capsule_meets_sphere(
    oc: Vec3,
    or: f32,
    lc: Vec3,
    lr: f32,
    bc: Vec3,
    br: f32,
) -> bool {
    let axis = lc - oc;
    let len = axis.length();
    let slack = br + 1e-6 * (1.0 + len);
    if len <= 1e-20 {
        return (bc - oc).length() <= slack + or.max(lr);
    }
    // d(s) = |bc - a(s)|, the radius r(s) = or + s (lr - or); minimise d(s) - r(s).
    let s0 = (bc - oc).dot(axis) / (len * len);
    let perp = (bc - (oc + axis * s0)).length();
    let grow = (lr - or) / len;
    let s = if grow.abs() < 1.0 {
        s0 + grow * perp / ((1.0 - grow * grow).sqrt() * len)
    } else if grow > 0.0 {
        1.0
    } else {
        0.0
    }
    .clamp(0.0, 1.0);
    (bc - (oc + axis * s)).length() - (or + s * (lr - or)) <= slack
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A group's sphere holds each of its blocks' spheres whole (so a group rejected is
    /// every block of it rejected: the capsule test is conservative for any origin in it).
    #[test]
    fn a_group_sphere_holds_its_blocks() {
        let mut rnd = crate::sampling::test_rng(777);
        for _ in 0..200 {
            let mut v = || Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            let blocks: Vec<(Vec3, f32)> = (0..GROUP)
                .map(|_| (v() * 10.0, v().x.abs() * 2.0))
                .collect();
            let (c, r) = group_sphere(&blocks);
            for (q, rq) in blocks {
                assert!((q - c).length() + rq <= r, "{q} {rq} outside {c} {r}");
            }
        }
    }

    /// The tapered capsule is conservative: any segment from a point of the first sphere to
    /// a point of the second that passes within the third is accepted; and it is tighter
    /// than the plain capsule: a sphere beside the thin end is rejected.
    #[test]
    fn capsule_test_accepts_every_segment_that_meets_the_sphere() {
        let mut rnd = crate::sampling::test_rng(12345);
        let mut v = |s: f32| Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * s;
        let mut accepted = 0;
        for _ in 0..20_000 {
            let (oc, or) = (v(4.0), 0.5 * v(1.0).x.abs());
            let (lc, lr) = (v(4.0) + Vec3::Y * 3.0, 2.0 * v(1.0).x.abs());
            let (t, r) = (v(1.0) + Vec3::splat(0.5), v(3.0));
            let (bc, br) = (oc.lerp(lc, t.x) + r, 0.2 + 0.5 * t.y);
            let unit = |mut d: Vec3| {
                while d.length() > 0.5 {
                    d *= 0.5;
                }
                d * 2.0
            };
            let y0 = oc + unit(v(1.0)) * or;
            let y1 = lc + unit(v(1.0)) * lr;
            // Closest point of the segment y0 y1 to bc.
            let d = y1 - y0;
            let t = ((bc - y0).dot(d) / d.length_squared().max(1e-30)).clamp(0.0, 1.0);
            if (bc - (y0 + d * t)).length() <= br {
                accepted += 1;
                assert!(
                    capsule_meets_sphere(oc, or, lc, lr, bc, br),
                    "{oc} {or} {lc} {lr} {bc} {br} {y0} {y1}"
                );
            }
        }
        assert!(accepted > 1000, "only {accepted} segments met the sphere");
        // Beside the thin end (radius 0.1 at the origin), 1.5 away, with a wide light far
        // above: the plain capsule (radius 5 everywhere) would accept it.
        let (oc, lc) = (Vec3::ZERO, Vec3::Y * 20.0);
        assert!(!capsule_meets_sphere(oc, 0.1, lc, 5.0, Vec3::X * 1.5, 0.2));
        assert!(capsule_meets_sphere(
            oc,
            0.1,
            lc,
            5.0,
            Vec3::new(1.5, 10.0, 0.0),
            0.2
        ));
    }
}
