//! Clamped-cosine convolution (irradiance) and ringing windows.
//!
//! By the Funk–Hecke theorem, convolving radiance `L` with the clamped
//! cosine `max(0, n·ω)` multiplies each band `l` by
//! `A_l = 2π ∫₀¹ t P_l(t) dt`:
//! `A_0 = π`, `A_1 = 2π/3`, `A_2 = π/4`, `A_3 = 0`, `A_4 = −π/24`, odd
//! `l > 1` zero, and for even `l ≥ 2`
//! `A_l = 2π (−1)^(l/2−1) / ((l+2)(l−1)) · l! / (2^l ((l/2)!)²)`.
//! Irradiance is `E(n) = ∫ L(ω) max(0, n·ω) dω = Σ_k A_l(k) L_k Y_k(n)`.
//!
//! Because `A_3 = 0`, 16-coefficient radiance gives exactly the same
//! irradiance as its first 9 coefficients.

use crate::{band_of, eval_basis, num_coeffs, ShRgb, MAX_BANDS, MAX_COEFFS};
use glam::Vec3;
use std::f64::consts::PI;

/// Clamped-cosine convolution factor `A_l` for band `l` (see module docs).
pub fn cosine_lobe(l: usize) -> f32 {
    match l {
        0 => PI as f32,
        1 => (2.0 * PI / 3.0) as f32,
        l if l % 2 == 1 => 0.0,
        l => {
            let fact = |n: usize| -> f64 { (1..=n).map(|i| i as f64).product() };
            let sign = if (l / 2 - 1) % 2 == 0 { 1.0 } else { -1.0 };
            let lf = l as f64;
            let h = fact(l / 2);
            (2.0 * PI * sign / ((lf + 2.0) * (lf - 1.0)) * fact(l) / (2f64.powi(l as i32) * h * h))
                as f32
        }
    }
}

/// Writes the per-coefficient clamped-cosine lobe around `normal`,
/// `out[k] = A_l(k) · Y_k(normal)`, for `bands` bands (`out[..bands²]`).
///
/// This is the paper's per-patch "form-factor SH" (Wang et al. 2007,
/// §2.3.1 item 2): store it once per patch, then irradiance is
/// `radiance_sh.dot(&lobe)` ([`ShRgb::dot`], [`irradiance_from_lobe`]).
/// Since `A_3 = 0`, `bands = 3` (9 floats) loses nothing against 4-band
/// radiance. `normal` must be a unit vector.
///
/// # Panics
/// If `bands` is not in `1..=MAX_BANDS` or `out.len() < bands²`.
pub fn cosine_lobe_sh(bands: usize, normal: Vec3, out: &mut [f32]) {
    eval_basis(bands, normal, out);
    for l in 0..bands {
        let a = cosine_lobe(l);
        for y in &mut out[l * l..(l + 1) * (l + 1)] {
            *y *= a;
        }
    }
}

/// Irradiance `max(0, Σ_k A_l(k) L_k Y_k(n))` per channel at unit normal
/// `normal` (clamped at zero: SH ringing can make it negative).
/// Allocation-free.
pub fn irradiance(sh: &ShRgb, normal: Vec3) -> Vec3 {
    let mut lobe = [0.0f32; MAX_COEFFS];
    cosine_lobe_sh(sh.bands(), normal, &mut lobe);
    irradiance_from_lobe(sh, &lobe[..sh.len()])
}

/// Irradiance from a precomputed lobe ([`cosine_lobe_sh`]):
/// `max(0, sh.dot(lobe))` per channel. The lobe may have fewer
/// coefficients than `sh` (truncation).
#[inline]
pub fn irradiance_from_lobe(sh: &ShRgb, lobe: &[f32]) -> Vec3 {
    sh.dot(lobe).max(Vec3::ZERO)
}

/// Multiplies each band of `sh` by `A_l`, turning radiance SH into
/// irradiance SH (`E(n) = sh.eval(n)` afterwards, unclamped).
pub fn convolve_cosine(sh: &mut ShRgb) {
    for l in 0..sh.bands() {
        let a = cosine_lobe(l);
        for c in &mut sh.coeffs_mut()[l * l..(l + 1) * (l + 1)] {
            *c *= a;
        }
    }
}

/// Per-band window to reduce ringing (Sloan, "Stupid SH tricks", §Windowing).
/// The parameter is the window width `w` in bands (typically `bands` or a
/// bit more; larger is gentler).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    /// No windowing (factor 1).
    None,
    /// Hanning: `(1 + cos(π l / w)) / 2` for `l < w`, 0 beyond.
    Hanning(f32),
    /// Lanczos sigma factor: `sin(π l / w) / (π l / w)` (1 at `l = 0`), 0
    /// for `l ≥ w`.
    Lanczos(f32),
}

/// Window factor for band `l`.
pub fn window_factor(window: Window, l: usize) -> f32 {
    let l = l as f32;
    match window {
        Window::None => 1.0,
        Window::Hanning(w) => {
            if l >= w {
                0.0
            } else {
                0.5 * (1.0 + (std::f32::consts::PI * l / w).cos())
            }
        }
        Window::Lanczos(w) => {
            if l == 0.0 {
                1.0
            } else if l >= w {
                0.0
            } else {
                let x = std::f32::consts::PI * l / w;
                x.sin() / x
            }
        }
    }
}

/// Multiplies each band of `sh` by [`window_factor`].
pub fn apply_window(sh: &mut ShRgb, window: Window) {
    debug_assert!(sh.bands() <= MAX_BANDS);
    for (k, c) in sh.coeffs_mut().iter_mut().enumerate() {
        *c *= window_factor(window, band_of(k));
    }
    debug_assert_eq!(sh.len(), num_coeffs(sh.bands()));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tests::Rng;
    use crate::{CubeMap, ShProjector};

    #[test]
    fn lobe_values() {
        let pi = std::f32::consts::PI;
        assert!((cosine_lobe(0) - pi).abs() < 1e-6);
        assert!((cosine_lobe(1) - 2.0 * pi / 3.0).abs() < 1e-6);
        assert!((cosine_lobe(2) - pi / 4.0).abs() < 1e-6);
        assert_eq!(cosine_lobe(3), 0.0);
        assert!((cosine_lobe(4) + pi / 24.0).abs() < 1e-6);
        assert_eq!(cosine_lobe(5), 0.0);
        assert!((cosine_lobe(6) - pi / 64.0).abs() < 1e-6);
        // A_l = 2π ∫₀¹ t P_l(t) dt, checked by numerical integration with
        // the Legendre recurrence.
        for l in 0..MAX_BANDS {
            let n = 20000;
            let mut s = 0.0f64;
            for i in 0..n {
                let t = (i as f64 + 0.5) / n as f64;
                let (mut p0, mut p1) = (1.0, t);
                let p = if l == 0 {
                    1.0
                } else {
                    for k in 2..=l {
                        let p2 = ((2 * k - 1) as f64 * t * p1 - (k - 1) as f64 * p0) / k as f64;
                        p0 = p1;
                        p1 = p2;
                    }
                    p1
                };
                s += t * p / n as f64;
            }
            assert!((cosine_lobe(l) as f64 - 2.0 * PI * s).abs() < 1e-6, "l={l}");
        }
    }

    #[test]
    fn furnace_constant_environment() {
        let cube = CubeMap::new(32);
        let proj = ShProjector::new(4, &cube);
        let sh = proj.project(&vec![Vec3::ONE; cube.len()]);
        let mut rng = Rng::new(2);
        for _ in 0..100 {
            let n = rng.dir();
            let e = irradiance(&sh, n);
            assert!((e - Vec3::splat(std::f32::consts::PI)).abs().max_element() < 1e-3);
        }
    }

    /// `L(ω) = max(0, ω·z)`. Its band-l zonal coefficient is (Funk–Hecke)
    /// `A_l sqrt((2l+1)/4π)`, so the 4-band irradiance at a normal at angle
    /// α from z is `Σ_{l<4} A_l² (2l+1)/(4π) P_l(cos α)`; at α = 0 that is
    /// `π(1/4 + 1/3 + 5/64) = 127π/192`, versus the exact `2π/3`: the
    /// truncation tail is exactly `π/192 ≈ 0.0164`. The kink of `L` lies on
    /// texel boundaries (even resolution), so the cube quadrature is
    /// second-order accurate; 2e-3 is generous at R = 64.
    #[test]
    fn clamped_cosine_environment() {
        let cube = CubeMap::new(64);
        let proj = ShProjector::new(4, &cube);
        let radiance: Vec<Vec3> = cube
            .directions
            .iter()
            .map(|d| Vec3::splat(d.z.max(0.0)))
            .collect();
        let sh = proj.project(&radiance);
        let pi = PI;
        let e = irradiance(&sh, Vec3::Z).x as f64;
        assert!((e - 127.0 * pi / 192.0).abs() < 2e-3, "{e}");
        assert!((e - 2.0 * pi / 3.0).abs() < pi / 192.0 + 2e-3);
        let legendre = |l: usize, t: f64| match l {
            0 => 1.0,
            1 => t,
            2 => 0.5 * (3.0 * t * t - 1.0),
            3 => 0.5 * (5.0 * t * t * t - 3.0 * t),
            _ => unreachable!(),
        };
        for alpha_deg in [0.0f64, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0] {
            let a = alpha_deg.to_radians();
            let n = Vec3::new(a.sin() as f32, 0.3 * a.sin() as f32, a.cos() as f32).normalize();
            let t = n.z as f64;
            let want: f64 = (0..4)
                .map(|l| {
                    (cosine_lobe(l) as f64).powi(2) * (2 * l + 1) as f64 / (4.0 * pi)
                        * legendre(l, t)
                })
                .sum();
            let got = irradiance(&sh, n).x as f64;
            assert!(
                (got - want.max(0.0)).abs() < 2e-3,
                "α={alpha_deg}: {got} vs {want}"
            );
        }
    }

    /// 16 and 9 coefficients give the same irradiance: the first 9
    /// coefficients of a 4-band projection are those of the 3-band one, and
    /// band 3 is annihilated by `A_3 = 0`. Differences are f32 round-off.
    #[test]
    fn nine_vs_sixteen_coefficients() {
        let cube = CubeMap::new(32);
        let p4 = ShProjector::new(4, &cube);
        let p3 = ShProjector::new(3, &cube);
        let mut rng = Rng::new(9);
        let radiance: Vec<Vec3> = cube
            .directions
            .iter()
            .map(|d| {
                Vec3::new(
                    (4.0 * d.x).sin().abs() + rng.f32(),
                    (d.y * 3.0 + d.z).exp(),
                    d.x.max(0.0).powi(8),
                )
            })
            .collect();
        let s4 = p4.project(&radiance);
        let s3 = p3.project(&radiance);
        let mut lobe9 = [0.0f32; 9];
        for _ in 0..200 {
            let n = rng.dir();
            let e4 = irradiance(&s4, n);
            let e3 = irradiance(&s3, n);
            cosine_lobe_sh(3, n, &mut lobe9);
            let e4_9 = irradiance_from_lobe(&s4, &lobe9);
            let tol = 1e-5 * e4.max_element().max(1.0);
            assert!((e4 - e3).abs().max_element() < tol);
            assert!((e4 - e4_9).abs().max_element() < tol);
        }
    }

    #[test]
    fn convolve_matches_irradiance_and_windows() {
        let mut rng = Rng::new(4);
        let coeffs: Vec<Vec3> = (0..25).map(|_| Vec3::splat(rng.sym())).collect();
        let sh = ShRgb::from_coeffs(coeffs);
        let mut conv = sh.clone();
        convolve_cosine(&mut conv);
        for _ in 0..50 {
            let n = rng.dir();
            let a = irradiance(&sh, n);
            let b = conv.eval(n).max(Vec3::ZERO);
            assert!((a - b).abs().max_element() < 1e-5);
        }
        assert_eq!(window_factor(Window::Hanning(4.0), 0), 1.0);
        assert_eq!(window_factor(Window::Hanning(4.0), 4), 0.0);
        assert!((window_factor(Window::Hanning(4.0), 2) - 0.5).abs() < 1e-6);
        assert!((window_factor(Window::Lanczos(4.0), 2) - 2.0 / std::f32::consts::PI).abs() < 1e-6);
        let mut w = sh.clone();
        apply_window(&mut w, Window::Hanning(5.0));
        assert_eq!(w[0], sh[0]);
        assert!(w[24].abs().max_element() < sh[24].abs().max_element());
        let mut w = sh.clone();
        apply_window(&mut w, Window::None);
        assert_eq!(w, sh);
    }
}
