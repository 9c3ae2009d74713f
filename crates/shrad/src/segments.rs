//! Many segments from one point against a few boxes at once: a slab test over arrays of
//! up to 64 segment ends, which the compiler vectorises (the direct light's stored shadow
//! rays, `direct/sample_ends.rs`, and the wall rows' rays, `dispersive/wall_rows/check.rs`,
//! are tested 64 at a time; a call per ray was a third of finding a mover's shadow rays).

use glam::Vec3;
use shrad_scene::Aabb;

/// Segments tested at once.
pub(crate) const LANES: usize = 64;

/// Segment ends relative to their common origin, x, y and z apart (`[axis][segment]`).
pub(crate) type Offsets = [[f32; LANES]; 3];

/// Bit `j` set where the segment from `from` to `from + d[..][j]` (`j < n <= 64`) meets one
/// of `boxes` (closed boxes; a segment along an axis is handled).
pub(crate) fn meeting(from: Vec3, d: &Offsets, n: usize, boxes: &[Aabb]) -> u64 {
    debug_assert!(n <= LANES);
    // Whole lanes of 8 (the lanes past `n` are tested too and their bits dropped).
    let lanes = n.next_multiple_of(8).min(LANES);
    let mut mask = 0u64;
    for b in boxes {
        let (bmin, bmax) = (b.min - from, b.max - from);
        let mut near = [0f32; LANES];
        let mut far = [1f32; LANES];
        for a in 0..3 {
            let inside = bmin[a] <= 0.0 && 0.0 <= bmax[a];
            for j in 0..lanes {
                let (t0, t1) = if d[a][j] == 0.0 {
                    match inside {
                        true => (f32::NEG_INFINITY, f32::INFINITY),
                        false => (f32::INFINITY, f32::NEG_INFINITY),
                    }
                } else {
                    let inv = 1.0 / d[a][j];
                    let (u, v) = (bmin[a] * inv, bmax[a] * inv);
                    (u.min(v), u.max(v))
                };
                near[j] = near[j].max(t0);
                far[j] = far[j].min(t1);
            }
        }
        for j in 0..n {
            mask |= u64::from(far[j] >= near[j]) << j;
        }
    }
    mask
}
