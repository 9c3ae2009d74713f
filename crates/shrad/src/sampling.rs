//! Small deterministic sampling helpers (no global RNG: every sample is a hash of its
//! indices, so results do not depend on thread scheduling).

use glam::Vec3;
use std::f32::consts::TAU;

/// A 32-bit integer hash (PCG output permutation).
pub fn hash(mut x: u32) -> u32 {
    x = x.wrapping_mul(747796405).wrapping_add(2891336453);
    let w = ((x >> ((x >> 28) + 4)) ^ x).wrapping_mul(277803737);
    (w >> 22) ^ w
}

/// A hash of two integers.
pub fn hash2(a: u32, b: u32) -> u32 {
    hash(a ^ hash(b).rotate_left(13))
}

/// A number in [0,1) from a hash.
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// `0..n` in a random order fixed by `seed` (Fisher-Yates on [`hash`]): pairs a patch's
/// stratified points with its stratified directions without correlating them.
pub fn shuffled(n: usize, seed: u32) -> Vec<u32> {
    let mut perm: Vec<u32> = (0..n as u32).collect();
    let mut state = hash(seed ^ 0x2545_f491);
    for k in (1..n).rev() {
        state = hash(state);
        perm.swap(k, (state as usize) % (k + 1));
    }
    perm
}

/// Point `i` of an `n`-point 2D Hammersley set, toroidally shifted by `shift`.
pub fn hammersley(i: u32, n: u32, shift: (f32, f32)) -> (f32, f32) {
    let u = (i as f32 + 0.5) / n as f32;
    let v = i.reverse_bits() as f32 * (1.0 / 4294967296.0);
    ((u + shift.0).fract(), (v + shift.1).fract())
}

/// An orthonormal basis `(t, b)` around unit `n` (Duff et al. 2017).
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction about unit `n` from `(u, v)` in [0,1)^2 (pdf `cos / pi`).
pub fn square_to_cosine_hemisphere(u: f32, v: f32, n: Vec3) -> Vec3 {
    let r = u.sqrt();
    let phi = TAU * v;
    let (t, b) = basis(n);
    let z = (1.0 - u).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize()
}

/// A small seeded generator of numbers in [0, 1) for tests (a 64-bit LCG's top 24 bits): the
/// same sequence on every run and machine.
#[cfg(test)]
pub(crate) fn test_rng(mut seed: u64) -> impl FnMut() -> f32 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 40) as f32) / (1u64 << 24) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_are_in_the_hemisphere_with_mean_cos_two_thirds() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let m = 4096;
        let mean: f32 = (0..m)
            .map(|i| {
                let (u, v) = hammersley(i, m, (0.0, 0.0));
                let d = square_to_cosine_hemisphere(u, v, n);
                assert!(d.dot(n) >= -1e-6);
                d.dot(n)
            })
            .sum::<f32>()
            / m as f32;
        assert!((mean - 2.0 / 3.0).abs() < 2e-3, "{mean}");
    }
}
