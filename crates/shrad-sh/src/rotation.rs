//! Rotation of SH coefficient vectors.
//!
//! Convention: rotating a function `f` by the rotation `R` gives
//! `g(ω) = f(R⁻¹ ω)` — a lobe pointing along `d` ends up pointing along
//! `R d` — so `g.eval(R ω) == f.eval(ω)`.
//!
//! Method: rotation acts band by band; the band-`l` block is
//! `D^l_ab = ∫ Y_a(R u) Y_b(u) du` (from `g_a = ∫ f(R⁻¹ω) Y_a(ω) dω`,
//! substituting `ω = R u`). The integrand is a spherical polynomial of
//! degree `2l ≤ 14`, so a product rule with 8 Gauss–Legendre nodes in `z`
//! and 16 equally spaced angles in `φ` (exact to degree 15, 128 points)
//! evaluates it *exactly* up to rounding — no Wigner recurrences and no sign
//! bookkeeping, valid for the basis exactly as implemented. Construction
//! costs ~256 basis evaluations plus `128 · Σ(2l+1)²` multiply-adds (tens
//! of µs for 8 bands); applying it is `Σ(2l+1)²` multiply-adds per channel.

use crate::{eval_basis, num_coeffs, ShRgb, MAX_BANDS, MAX_COEFFS};
use glam::{Mat3, Quat, Vec3};

/// Number of Gauss–Legendre nodes (exact to polynomial degree 15 ≥ 2·7).
const GL_NODES: usize = 8;
/// Number of azimuthal samples (exact for frequencies < 16 > 14).
const PHI_SAMPLES: usize = 16;

/// Gauss–Legendre nodes and weights on `[-1, 1]` (Newton on `P_n`).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 1..=n {
        let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// A precomputed SH rotation for up to `bands` bands (block-diagonal, one
/// `(2l+1)²` block per band). See the module docs for the convention.
#[derive(Clone, Debug)]
pub struct ShRotation {
    bands: usize,
    /// Blocks concatenated; block `l` starts at `Σ_{j<l} (2j+1)²`, row-major
    /// (`D^l[a][b]`, `a` = output index within the band).
    blocks: Vec<f32>,
}

/// Offset of band `l`'s block: `Σ_{j<l} (2j+1)² = l(4l²-1)/3`.
#[inline]
fn block_offset(l: usize) -> usize {
    (4 * l * l * l - l) / 3
}

impl ShRotation {
    /// Builds the rotation by `rot` (a proper rotation matrix) for `bands`
    /// bands.
    ///
    /// # Panics
    /// If `bands` is not in `1..=MAX_BANDS`.
    pub fn new(bands: usize, rot: Mat3) -> Self {
        assert!((1..=MAX_BANDS).contains(&bands), "bands out of range");
        let mut acc = vec![0.0f64; block_offset(bands)];
        let n = num_coeffs(bands);
        let mut yu = [0.0f32; MAX_COEFFS];
        let mut yr = [0.0f32; MAX_COEFFS];
        let dphi = 2.0 * std::f64::consts::PI / PHI_SAMPLES as f64;
        for (z, wz) in gauss_legendre(GL_NODES) {
            let r = (1.0 - z * z).max(0.0).sqrt();
            for j in 0..PHI_SAMPLES {
                let (s, c) = (j as f64 * dphi).sin_cos();
                let u = glam::DVec3::new(r * c, r * s, z);
                let w = wz * dphi;
                let ru = rot.as_dmat3() * u;
                eval_basis(bands, u.as_vec3(), &mut yu);
                eval_basis(bands, ru.normalize().as_vec3(), &mut yr);
                for l in 0..bands {
                    let base = l * l;
                    let dim = 2 * l + 1;
                    let off = block_offset(l);
                    for a in 0..dim {
                        let wa = w * yr[base + a] as f64;
                        let row = &mut acc[off + a * dim..off + (a + 1) * dim];
                        for (b, x) in row.iter_mut().enumerate() {
                            *x += wa * yu[base + b] as f64;
                        }
                    }
                }
            }
        }
        debug_assert!(n <= MAX_COEFFS);
        ShRotation {
            bands,
            blocks: acc.into_iter().map(|x| x as f32).collect(),
        }
    }

    /// Builds the rotation by the unit quaternion `q`.
    pub fn from_quat(bands: usize, q: Quat) -> Self {
        Self::new(bands, Mat3::from_quat(q))
    }

    /// Number of bands.
    #[inline]
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// The `(2l+1)×(2l+1)` row-major block of band `l`.
    pub fn band_matrix(&self, l: usize) -> &[f32] {
        assert!(l < self.bands);
        &self.blocks[block_offset(l)..block_offset(l + 1)]
    }

    /// Rotates the scalar coefficient vector `input` (length `n²`,
    /// `n ≤ bands()`) into `out[..n²]`.
    ///
    /// # Panics
    /// If `input` has an unsupported length, more bands than the rotation,
    /// or `out` is too short.
    pub fn rotate(&self, input: &[f32], out: &mut [f32]) {
        let nb = crate::bands_for_len(input.len()).expect("input length must be n²");
        assert!(nb <= self.bands, "input has more bands than the rotation");
        assert!(out.len() >= input.len(), "output slice too short");
        for l in 0..nb {
            let dim = 2 * l + 1;
            let m = self.band_matrix(l);
            let x = &input[l * l..l * l + dim];
            for a in 0..dim {
                let row = &m[a * dim..(a + 1) * dim];
                out[l * l + a] = row.iter().zip(x).map(|(r, v)| r * v).sum();
            }
        }
    }

    /// Rotates RGB coefficients `input` into `out` (same bands, at most
    /// `bands()`); no allocation.
    pub fn rotate_rgb(&self, input: &ShRgb, out: &mut ShRgb) {
        assert!(
            input.bands() <= self.bands,
            "input has more bands than the rotation"
        );
        assert_eq!(input.bands(), out.bands(), "band mismatch");
        let x = input.coeffs();
        let o = out.coeffs_mut();
        for l in 0..input.bands() {
            let dim = 2 * l + 1;
            let m = self.band_matrix(l);
            for a in 0..dim {
                let row = &m[a * dim..(a + 1) * dim];
                let mut acc = Vec3::ZERO;
                for (r, v) in row.iter().zip(&x[l * l..l * l + dim]) {
                    acc += *v * *r;
                }
                o[l * l + a] = acc;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tests::Rng;

    fn random_rot(rng: &mut Rng) -> Mat3 {
        let q = Quat::from_axis_angle(rng.dir(), rng.f32() * std::f32::consts::TAU);
        Mat3::from_quat(q)
    }

    fn eval_scalar(c: &[f32], d: Vec3) -> f32 {
        let bands = crate::bands_for_len(c.len()).unwrap();
        let mut y = [0.0f32; MAX_COEFFS];
        eval_basis(bands, d, &mut y);
        c.iter().zip(&y).map(|(a, b)| a * b).sum()
    }

    #[test]
    fn gauss_legendre_exact() {
        let gl = gauss_legendre(GL_NODES);
        for p in 0..16 {
            let s: f64 = gl.iter().map(|(x, w)| w * x.powi(p)).sum();
            let want = if p % 2 == 1 {
                0.0
            } else {
                2.0 / (p + 1) as f64
            };
            assert!((s - want).abs() < 1e-13, "degree {p}");
        }
    }

    #[test]
    fn rotated_function_matches() {
        let mut rng = Rng::new(21);
        for bands in 1..=MAX_BANDS {
            for _ in 0..5 {
                let n = bands * bands;
                let c: Vec<f32> = (0..n).map(|_| rng.sym()).collect();
                let r = random_rot(&mut rng);
                let rot = ShRotation::new(bands, r);
                let mut g = vec![0.0f32; n];
                rot.rotate(&c, &mut g);
                let norm_c: f32 = c.iter().map(|x| x * x).sum::<f32>().sqrt();
                let norm_g: f32 = g.iter().map(|x| x * x).sum::<f32>().sqrt();
                assert!(
                    (norm_c - norm_g).abs() < 1e-5 * norm_c,
                    "norm, bands {bands}"
                );
                // Scale of the function values: |f(ω)| ≤ |c| sqrt(n/4π).
                let scale = norm_c * (n as f32 / (4.0 * std::f32::consts::PI)).sqrt();
                for _ in 0..50 {
                    let w = rng.dir();
                    let f = eval_scalar(&c, w);
                    let gv = eval_scalar(&g, (r * w).normalize());
                    assert!(
                        (f - gv).abs() < 1e-4 * scale,
                        "bands {bands}: {f} vs {gv} (scale {scale})"
                    );
                }
            }
        }
    }

    #[test]
    fn identity_composition_and_band1() {
        let mut rng = Rng::new(5);
        let id = ShRotation::new(8, Mat3::IDENTITY);
        for l in 0..8 {
            let m = id.band_matrix(l);
            let dim = 2 * l + 1;
            for a in 0..dim {
                for b in 0..dim {
                    let want = if a == b { 1.0 } else { 0.0 };
                    assert!((m[a * dim + b] - want).abs() < 1e-6);
                }
            }
        }
        let c: Vec<f32> = (0..64).map(|_| rng.sym()).collect();
        let mut g = vec![0.0; 64];
        id.rotate(&c, &mut g);
        for k in 0..64 {
            assert!((c[k] - g[k]).abs() < 1e-5);
        }
        // Composition: rot(R2) ∘ rot(R1) == rot(R2 R1).
        let (r1, r2) = (random_rot(&mut rng), random_rot(&mut rng));
        let (a, b, ab) = (
            ShRotation::new(8, r1),
            ShRotation::new(8, r2),
            ShRotation::new(8, r2 * r1),
        );
        let (mut t, mut u, mut v) = (vec![0.0; 64], vec![0.0; 64], vec![0.0; 64]);
        a.rotate(&c, &mut t);
        b.rotate(&t, &mut u);
        ab.rotate(&c, &mut v);
        for k in 0..64 {
            assert!((u[k] - v[k]).abs() < 1e-4);
        }
        // Band 1 is R itself in the (y, z, x) ordering.
        let r = random_rot(&mut rng);
        let m = ShRotation::new(2, r);
        let b1 = m.band_matrix(1);
        let perm = [1usize, 2, 0];
        for a in 0..3 {
            for b in 0..3 {
                assert!((b1[a * 3 + b] - r.col(perm[b])[perm[a]]).abs() < 1e-5);
            }
        }
        // RGB version and fewer input bands.
        let sh = ShRgb::from_coeffs((0..16).map(|_| Vec3::new(rng.sym(), 1.0, 0.0)).collect());
        let mut out = ShRgb::zeros(4);
        let big = ShRotation::from_quat(8, Quat::from_mat3(&r));
        big.rotate_rgb(&sh, &mut out);
        let w = rng.dir();
        assert!((sh.eval(w) - out.eval(r * w)).abs().max_element() < 1e-4);
    }
}
