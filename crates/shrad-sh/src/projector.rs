//! Projection of cube-map radiance onto SH.

use crate::{eval_basis, num_coeffs, CubeMap, ShRgb, MAX_BANDS, MAX_COEFFS};
use glam::Vec3;

/// Texels accumulated in `f32` before flushing into the `f64` totals:
/// keeps the inner loop in `f32` (vectorisable) while bounding round-off.
const BLOCK: usize = 1024;

/// Precomputed projection weights `Y_k(ω_t) · dω_t` for every texel `t` of a
/// [`CubeMap`], stored texel-major (`weights[t·n + k]`, `n = bands²`), so
/// that projecting is one streaming pass of `n`-wide multiply-adds.
///
/// `project` computes `L_k = Σ_t L(ω_t) Y_k(ω_t) dω_t ≈ ∫ L Y_k dω`.
#[derive(Clone, Debug)]
pub struct ShProjector {
    bands: usize,
    texels: usize,
    res: usize,
    weights: Vec<f32>,
    /// The same weights coefficient-major (`by_coeff[k·texels + t]`), for
    /// [`ShProjector::texel_values`].
    by_coeff: Vec<f32>,
}

impl ShProjector {
    /// Precomputes the weights for `bands` bands over `cube`.
    ///
    /// # Panics
    /// If `bands` is not in `1..=MAX_BANDS`.
    pub fn new(bands: usize, cube: &CubeMap) -> Self {
        assert!((1..=MAX_BANDS).contains(&bands), "bands out of range");
        let n = num_coeffs(bands);
        let mut weights = vec![0.0f32; cube.len() * n];
        let mut y = [0.0f32; MAX_COEFFS];
        for ((w, &d), &sa) in weights
            .chunks_exact_mut(n)
            .zip(&cube.directions)
            .zip(&cube.solid_angles)
        {
            eval_basis(bands, d, &mut y);
            for k in 0..n {
                w[k] = y[k] * sa;
            }
        }
        let texels = cube.len();
        let mut by_coeff = vec![0.0f32; texels * n];
        for (t, w) in weights.chunks_exact(n).enumerate() {
            for k in 0..n {
                by_coeff[k * texels + t] = w[k];
            }
        }
        ShProjector {
            bands,
            texels,
            res: cube.res(),
            weights,
            by_coeff,
        }
    }

    /// Number of bands.
    #[inline]
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// Number of coefficients (`bands²`).
    #[inline]
    pub fn num_coeffs(&self) -> usize {
        num_coeffs(self.bands)
    }

    /// Number of texels (`6·res²`) expected by `project`.
    #[inline]
    pub fn texels(&self) -> usize {
        self.texels
    }

    /// Cube-map resolution (texels per face edge).
    #[inline]
    pub fn res(&self) -> usize {
        self.res
    }

    /// The weight table, texel-major: `weights()[t·n + k] = Y_k(ω_t) dω_t`.
    #[inline]
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// The SH function `sh` at texel `t` times the texel's solid angle,
    /// `Σ_k sh_k Y_k(ω_t) dω_t` (e.g. an intensity in SH becomes the flux
    /// through the texel): a dot product with the stored weights, no basis
    /// evaluation.
    ///
    /// # Panics
    /// If `t >= texels()`.
    #[inline]
    pub fn texel_value(&self, sh: &ShRgb, t: usize) -> Vec3 {
        let n = self.num_coeffs();
        sh.dot(&self.weights[t * n..(t + 1) * n])
    }

    /// [`ShProjector::texel_value`] of every texel, `out[t]` (the same floats:
    /// the terms are summed in the same order), a run of texels at a time,
    /// which vectorises.
    ///
    /// # Panics
    /// If `out.len() != texels()`.
    pub fn texel_values(&self, sh: &ShRgb, out: &mut [Vec3]) {
        assert_eq!(out.len(), self.texels, "texel_values: length mismatch");
        const RUN: usize = 256;
        let n = self.num_coeffs().min(sh.len());
        for (b, out) in out.chunks_mut(RUN).enumerate() {
            let lo = b * RUN;
            let m = out.len();
            let (mut r, mut g, mut bl) = ([0f32; RUN], [0f32; RUN], [0f32; RUN]);
            for (k, c) in sh.coeffs()[..n].iter().enumerate() {
                let col = &self.by_coeff[k * self.texels + lo..k * self.texels + lo + m];
                for (i, &w) in col.iter().enumerate() {
                    r[i] += c.x * w;
                    g[i] += c.y * w;
                    bl[i] += c.z * w;
                }
            }
            for (i, o) in out.iter_mut().enumerate() {
                *o = Vec3::new(r[i], g[i], bl[i]);
            }
        }
    }

    /// Projects per-texel radiance (`radiance.len() == texels()`, cube-map
    /// layout) to SH.
    ///
    /// # Panics
    /// If the length does not match.
    pub fn project(&self, radiance: &[Vec3]) -> ShRgb {
        let mut out = ShRgb::zeros(self.bands);
        self.project_into(radiance, &mut out);
        out
    }

    /// Like [`ShProjector::project`], writing into `out` (must have
    /// `bands()` bands); no allocation.
    pub fn project_into(&self, radiance: &[Vec3], out: &mut ShRgb) {
        assert_eq!(radiance.len(), self.texels, "radiance length mismatch");
        self.project_with_into(|t| radiance[t], out);
    }

    /// Projects radiance given per texel by a closure, e.g.
    /// `|t| palette[hit_id[t] as usize]` when the cube map holds hit ids and
    /// the radiosities live in a table. The closure is called exactly once
    /// per texel, in increasing order.
    pub fn project_indexed(&self, texel_value: impl FnMut(usize) -> Vec3) -> ShRgb {
        let mut out = ShRgb::zeros(self.bands);
        self.project_with_into(texel_value, &mut out);
        out
    }

    /// Allocation-free form of [`ShProjector::project_indexed`]; `out` must
    /// have `bands()` bands and is overwritten.
    pub fn project_with_into(&self, texel_value: impl FnMut(usize) -> Vec3, out: &mut ShRgb) {
        assert_eq!(out.bands(), self.bands, "output band mismatch");
        let out = out.coeffs_mut();
        match self.bands {
            1 => project_impl::<1>(&self.weights, texel_value, out),
            2 => project_impl::<4>(&self.weights, texel_value, out),
            3 => project_impl::<9>(&self.weights, texel_value, out),
            4 => project_impl::<16>(&self.weights, texel_value, out),
            5 => project_impl::<25>(&self.weights, texel_value, out),
            6 => project_impl::<36>(&self.weights, texel_value, out),
            7 => project_impl::<49>(&self.weights, texel_value, out),
            8 => project_impl::<64>(&self.weights, texel_value, out),
            _ => unreachable!(),
        }
    }

    /// Projects a scalar function given per texel (`values.len() ==
    /// texels()`) into `out[..bands²]`.
    pub fn project_scalar_into(&self, values: &[f32], out: &mut [f32]) {
        assert_eq!(values.len(), self.texels, "values length mismatch");
        let n = self.num_coeffs();
        assert!(out.len() >= n, "output slice too short");
        let mut tot = [0.0f64; MAX_COEFFS];
        for (wb, vb) in self.weights.chunks(BLOCK * n).zip(values.chunks(BLOCK)) {
            let mut acc = [0.0f32; MAX_COEFFS];
            for (w, &v) in wb.chunks_exact(n).zip(vb) {
                for k in 0..n {
                    acc[k] += w[k] * v;
                }
            }
            for k in 0..n {
                tot[k] += acc[k] as f64;
            }
        }
        for k in 0..n {
            out[k] = tot[k] as f32;
        }
    }
}

#[inline(always)]
fn project_impl<const N: usize>(
    weights: &[f32],
    mut texel_value: impl FnMut(usize) -> Vec3,
    out: &mut [Vec3],
) {
    let mut tr = [0.0f64; N];
    let mut tg = [0.0f64; N];
    let mut tb = [0.0f64; N];
    let mut t = 0usize;
    for wb in weights.chunks(BLOCK * N) {
        let mut ar = [0.0f32; N];
        let mut ag = [0.0f32; N];
        let mut ab = [0.0f32; N];
        for w in wb.chunks_exact(N) {
            let w: &[f32; N] = w.try_into().unwrap();
            let c = texel_value(t);
            t += 1;
            for k in 0..N {
                ar[k] += w[k] * c.x;
                ag[k] += w[k] * c.y;
                ab[k] += w[k] * c.z;
            }
        }
        for k in 0..N {
            tr[k] += ar[k] as f64;
            tg[k] += ag[k] as f64;
            tb[k] += ab[k] as f64;
        }
    }
    for k in 0..N {
        out[k] = Vec3::new(tr[k] as f32, tg[k] as f32, tb[k] as f32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tests::Rng;
    use crate::sh_index;
    use std::f32::consts::PI;

    fn gram_max_error(bands: usize, res: usize) -> f64 {
        let cube = CubeMap::new(res);
        let proj = ShProjector::new(bands, &cube);
        let n = bands * bands;
        let mut g = vec![0.0f64; n * n];
        let mut y = [0.0f32; MAX_COEFFS];
        for (t, &d) in cube.directions.iter().enumerate() {
            eval_basis(bands, d, &mut y);
            let w = &proj.weights()[t * n..(t + 1) * n];
            for i in 0..n {
                let wi = w[i] as f64;
                for j in 0..n {
                    g[i * n + j] += wi * y[j] as f64;
                }
            }
        }
        let mut worst = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((g[i * n + j] - want).abs());
            }
        }
        worst
    }

    #[test]
    fn texel_values_equal_texel_value_exactly() {
        let cube = CubeMap::new(9);
        let proj = ShProjector::new(4, &cube);
        let sh = ShRgb::from_coeffs(
            (0..16)
                .map(|k| Vec3::new(k as f32 * 0.37 - 2.0, 1.0 / (k as f32 + 1.5), 0.1))
                .collect(),
        );
        let mut out = vec![Vec3::NAN; proj.texels()];
        proj.texel_values(&sh, &mut out);
        for (t, o) in out.iter().enumerate() {
            assert_eq!(*o, proj.texel_value(&sh, t), "texel {t}");
        }
    }

    #[test]
    fn orthonormality_under_cube_quadrature() {
        let e4 = gram_max_error(4, 64);
        assert!(e4 < 1e-3, "4 bands: {e4}");
        let e8 = gram_max_error(8, 64);
        println!("max |G - I| at R=64: 4 bands {e4:.2e}, 8 bands {e8:.2e}");
        assert!(e8 < 1e-3, "8 bands: {e8}");
    }

    #[test]
    fn constant_environment() {
        let cube = CubeMap::new(32);
        let proj = ShProjector::new(4, &cube);
        let sh = proj.project(&vec![Vec3::ONE; cube.len()]);
        // L_00 = ∫ Y_00 = 4π / (2√π) = 2√π.
        assert!((sh[0] - Vec3::splat(2.0 * PI.sqrt())).abs().max_element() < 1e-5);
        for k in 1..16 {
            assert!(sh[k].abs().max_element() < 1e-4, "k={k}: {}", sh[k]);
        }
        // Closure and scalar variants agree.
        let sh2 = proj.project_indexed(|_| Vec3::ONE);
        assert_eq!(sh, sh2);
        let mut s = [0.0f32; 16];
        proj.project_scalar_into(&vec![1.0; cube.len()], &mut s);
        for k in 0..16 {
            assert!((s[k] - sh[k].x).abs() < 1e-6);
        }
    }

    #[test]
    fn band_limited_roundtrip() {
        // Projecting a band-limited function reproduces its coefficients up
        // to quadrature error.
        let cube = CubeMap::new(64);
        let proj = ShProjector::new(4, &cube);
        let mut rng = Rng::new(11);
        let coeffs: Vec<Vec3> = (0..16)
            .map(|_| Vec3::new(rng.sym(), rng.sym(), rng.sym()))
            .collect();
        let f = ShRgb::from_coeffs(coeffs);
        let radiance: Vec<Vec3> = cube.directions.iter().map(|&d| f.eval(d)).collect();
        let g = proj.project(&radiance);
        for k in 0..16 {
            assert!((g[k] - f[k]).abs().max_element() < 3e-3, "k={k}");
        }
        // Texel values are the function times the solid angle.
        for t in (0..cube.len()).step_by(97) {
            let want = f.eval(cube.directions[t]) * cube.solid_angles[t];
            let got = proj.texel_value(&f, t);
            assert!((got - want).abs().max_element() <= 1e-5 * want.abs().max_element().max(1e-3));
        }
        // Palette form.
        let palette = [Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.5, 0.0, 0.0)];
        let ids: Vec<u32> = cube
            .directions
            .iter()
            .map(|d| u32::from(d.z > 0.0))
            .collect();
        let sh = proj.project_indexed(|t| palette[ids[t] as usize]);
        // Mean radiance: half of each colour.
        let mean = sh[sh_index(0, 0)] / (2.0 * PI.sqrt());
        assert!((mean - (palette[0] + palette[1]) * 0.5).abs().max_element() < 1e-4);
    }
}
