//! RGB SH coefficient vectors.

use crate::{eval_basis, num_coeffs, MAX_BANDS, MAX_COEFFS};
use glam::Vec3;
use std::ops::{AddAssign, Index, IndexMut, MulAssign};

/// An RGB spherical-harmonic expansion: `bands²` coefficients, each a
/// [`Vec3`] holding the R, G, B coefficient of the same basis function.
///
/// Coefficients are plain projections `L_k = ∫ L(ω) Y_k(ω) dω` (nothing
/// baked in; see the crate docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ShRgb {
    bands: usize,
    coeffs: Vec<Vec3>,
}

impl ShRgb {
    /// All-zero expansion with `bands` bands.
    ///
    /// # Panics
    /// If `bands` is not in `1..=MAX_BANDS`.
    pub fn zeros(bands: usize) -> Self {
        assert!((1..=MAX_BANDS).contains(&bands), "bands out of range");
        ShRgb {
            bands,
            coeffs: vec![Vec3::ZERO; num_coeffs(bands)],
        }
    }

    /// Wraps a coefficient vector; its length must be `n²`, `1 ≤ n ≤ 8`.
    ///
    /// # Panics
    /// If the length is not a supported square.
    pub fn from_coeffs(coeffs: Vec<Vec3>) -> Self {
        let bands = crate::bands_for_len(coeffs.len()).expect("length must be n², 1 <= n <= 8");
        ShRgb { bands, coeffs }
    }

    /// Number of bands.
    #[inline]
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// Number of coefficients (`bands²`).
    #[inline]
    pub fn len(&self) -> usize {
        self.coeffs.len()
    }

    /// Always `false` (at least one band).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.coeffs.is_empty()
    }

    /// The coefficients.
    #[inline]
    pub fn coeffs(&self) -> &[Vec3] {
        &self.coeffs
    }

    /// The coefficients, mutably.
    #[inline]
    pub fn coeffs_mut(&mut self) -> &mut [Vec3] {
        &mut self.coeffs
    }

    /// Sets every coefficient to zero.
    #[inline]
    pub fn set_zero(&mut self) {
        self.coeffs.fill(Vec3::ZERO);
    }

    /// `self += other` coefficient-wise (bands must match).
    #[inline]
    pub fn add(&mut self, other: &ShRgb) {
        assert_eq!(self.bands, other.bands, "band mismatch");
        for (a, b) in self.coeffs.iter_mut().zip(&other.coeffs) {
            *a += *b;
        }
    }

    /// `self += w · other` coefficient-wise (bands must match).
    #[inline]
    pub fn add_scaled(&mut self, other: &ShRgb, w: f32) {
        assert_eq!(self.bands, other.bands, "band mismatch");
        for (a, b) in self.coeffs.iter_mut().zip(&other.coeffs) {
            *a += *b * w;
        }
    }

    /// `self *= s`.
    #[inline]
    pub fn scale(&mut self, s: f32) {
        for a in &mut self.coeffs {
            *a *= s;
        }
    }

    /// `out = Σ_i weights[i] · probes[i]` — the trilinear interpolation of
    /// 8 probes (see [`trilinear_weights`]); no allocation. All bands must
    /// match `out`.
    pub fn lerp8_into(probes: &[&ShRgb; 8], weights: &[f32; 8], out: &mut ShRgb) {
        Self::weighted_sum_into(probes.iter().copied().zip(weights.iter().copied()), out);
    }

    /// Allocating version of [`ShRgb::lerp8_into`].
    pub fn lerp8(probes: &[&ShRgb; 8], weights: &[f32; 8]) -> ShRgb {
        let mut out = ShRgb::zeros(probes[0].bands);
        Self::lerp8_into(probes, weights, &mut out);
        out
    }

    /// `out = Σ w · sh` over the `(sh, w)` pairs (out is overwritten); all
    /// bands must match `out`.
    pub fn weighted_sum_into<'a>(
        terms: impl IntoIterator<Item = (&'a ShRgb, f32)>,
        out: &mut ShRgb,
    ) {
        out.set_zero();
        for (sh, w) in terms {
            out.add_scaled(sh, w);
        }
    }

    /// `Σ_k L_k · w_k` over the first `min(len(), w.len())` coefficients
    /// (RGB result). With `w = `[`cosine_lobe_sh`](crate::cosine_lobe_sh)
    /// this is the irradiance (unclamped). A shorter `w` truncates the
    /// expansion, e.g. a 9-coefficient lobe against 16-coefficient radiance
    /// is exact since `A_3 = 0`.
    #[inline]
    pub fn dot(&self, w: &[f32]) -> Vec3 {
        let mut acc = Vec3::ZERO;
        for (c, &w) in self.coeffs.iter().zip(w) {
            acc += *c * w;
        }
        acc
    }

    /// Reconstructs the function at unit direction `dir`:
    /// `Σ_k L_k Y_k(dir)`.
    pub fn eval(&self, dir: Vec3) -> Vec3 {
        let mut y = [0.0f32; MAX_COEFFS];
        eval_basis(self.bands, dir, &mut y);
        self.dot(&y[..self.len()])
    }

    /// `out[n] = self.eval(d_n)` for the directions `d_n = (x[n], y[n], z[n])` (the same
    /// floats), faster up to 4 bands: one basis function at a time over the directions.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn eval_many(&self, x: &[f32], y: &[f32], z: &[f32], out: &mut [Vec3]) {
        assert!(
            x.len() == out.len() && y.len() == out.len() && z.len() == out.len(),
            "eval_many: lengths differ"
        );
        if self.bands <= 4 {
            // Zero terms beyond the bands leave every sum as it was.
            let mut c = [Vec3::ZERO; 16];
            c[..self.len()].copy_from_slice(&self.coeffs);
            crate::basis::dot_basis_4_many(&c, x, y, z, out);
        } else {
            for (n, o) in out.iter_mut().enumerate() {
                *o = self.eval(Vec3::new(x[n], y[n], z[n]));
            }
        }
    }

    /// Copies the first `min` bands of `self` into `out`, zero-filling any
    /// extra bands of `out` (band truncation / extension).
    pub fn resize_into(&self, out: &mut ShRgb) {
        let n = self.len().min(out.len());
        out.coeffs[..n].copy_from_slice(&self.coeffs[..n]);
        out.coeffs[n..].fill(Vec3::ZERO);
    }
}

impl Index<usize> for ShRgb {
    type Output = Vec3;
    #[inline]
    fn index(&self, i: usize) -> &Vec3 {
        &self.coeffs[i]
    }
}

impl IndexMut<usize> for ShRgb {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut Vec3 {
        &mut self.coeffs[i]
    }
}

impl AddAssign<&ShRgb> for ShRgb {
    #[inline]
    fn add_assign(&mut self, rhs: &ShRgb) {
        self.add(rhs);
    }
}

impl MulAssign<f32> for ShRgb {
    #[inline]
    fn mul_assign(&mut self, rhs: f32) {
        self.scale(rhs);
    }
}

/// Trilinear weights of the 8 corners of a box for local coordinates
/// `t ∈ [0,1]³` (0 at the min corner). Corner `i` has
/// `x = bit 0, y = bit 1, z = bit 2` of `i` (corner 0 = min, 7 = max).
/// The weights sum to 1; `t` is not clamped.
#[inline]
pub fn trilinear_weights(t: Vec3) -> [f32; 8] {
    let s = Vec3::ONE - t;
    let mut w = [0.0f32; 8];
    for (i, wi) in w.iter_mut().enumerate() {
        let fx = if i & 1 != 0 { t.x } else { s.x };
        let fy = if i & 2 != 0 { t.y } else { s.y };
        let fz = if i & 4 != 0 { t.z } else { s.z };
        *wi = fx * fy * fz;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `eval_many` gives the floats of `eval`, not just close ones (the dispersive Step 3
    /// cache relies on it to be exact).
    #[test]
    fn eval_many_equals_eval_exactly() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for bands in [1, 2, 3, 4, 5] {
            let n = bands * bands;
            let sh =
                ShRgb::from_coeffs((0..n).map(|_| Vec3::new(next(), next(), next())).collect());
            let dirs: Vec<Vec3> = (0..37)
                .map(|_| Vec3::new(next(), next(), next()).normalize())
                .collect();
            let [x, y, z] = [0, 1, 2].map(|a| dirs.iter().map(|d| d[a]).collect::<Vec<f32>>());
            let mut out = vec![Vec3::NAN; dirs.len()];
            sh.eval_many(&x, &y, &z, &mut out);
            for (d, o) in dirs.iter().zip(&out) {
                assert_eq!(*o, sh.eval(*d), "{bands} bands at {d}");
            }
        }
    }

    #[test]
    fn arithmetic_and_lerp8() {
        let mk = |s: f32| {
            ShRgb::from_coeffs(
                (0..16)
                    .map(|k| Vec3::new(k as f32, s, -s))
                    .collect::<Vec<_>>(),
            )
        };
        let probes: Vec<ShRgb> = (0..8).map(|i| mk(i as f32)).collect();
        let refs: [&ShRgb; 8] = std::array::from_fn(|i| &probes[i]);
        let w = trilinear_weights(Vec3::new(0.25, 0.5, 1.0));
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        // z = 1: only corners with bit 2 set contribute.
        assert!(w[..4].iter().all(|&x| x == 0.0));
        let out = ShRgb::lerp8(&refs, &w);
        let want_s: f32 = (0..8).map(|i| w[i] * i as f32).sum();
        for k in 0..16 {
            assert!((out[k] - Vec3::new(k as f32, want_s, -want_s)).length() < 1e-5);
        }
        let mut a = mk(1.0);
        a += &mk(2.0);
        a *= 0.5;
        assert_eq!(a[3], Vec3::new(3.0, 1.5, -1.5));
        let d = a.dot(&[1.0, 0.0, 0.0, 2.0]);
        assert_eq!(d, a[0] + 2.0 * a[3]);
        let mut small = ShRgb::zeros(2);
        a.resize_into(&mut small);
        assert_eq!(small.coeffs(), &a.coeffs()[..4]);
    }
}
