//! Real spherical harmonics, cube-map quadrature and clamped-cosine
//! convolution for shrad.
//!
//! This crate implements the SH machinery of Wang, Liu & Wu 2007,
//! *"Dispersive calculation of global illumination based on spherical
//! harmonics method"*: light probes are captured as cube maps
//! ([`CubeMap`]), projected to SH ([`ShProjector`]), interpolated
//! trilinearly ([`ShRgb::lerp8_into`]) and dotted with a clamped-cosine lobe
//! ([`cosine_lobe_sh`], [`irradiance`]). Rotation ([`ShRotation`]) and
//! ringing windows ([`Window`]) complete the toolbox. The layout follows
//! filament's `libs/ibl` `CubemapSH`.
//!
//! # Conventions
//!
//! * **Bands.** `bands = n` means degrees `l = 0..n` and `n²` coefficients;
//!   `1 ≤ n ≤` [`MAX_BANDS`] `= 8`. The default is [`DEFAULT_BANDS`] `= 4`
//!   (16 coefficients).
//! * **Index.** Coefficient `(l, m)`, `-l ≤ m ≤ l`, lives at
//!   [`sh_index`]`(l, m) = l(l+1) + m`.
//! * **Normalisation.** The basis is *real* and *orthonormal* over the unit
//!   sphere: `∫ Y_i Y_j dω = δ_ij` (so `Y_00 = 1/(2√π)`).
//! * **Definition / sign.** With `K_l^m = sqrt((2l+1)/(4π) · (l-|m|)!/(l+|m|)!)`
//!   and `P_l^m` the associated Legendre function **without** the
//!   Condon–Shortley phase (`P_1^1(cos θ) = +sin θ`):
//!   `Y_l^m = √2 K_l^m cos(mφ) P_l^m(cos θ)` for `m > 0`,
//!   `Y_l^m = √2 K_l^|m| sin(|m|φ) P_l^|m|(cos θ)` for `m < 0`,
//!   `Y_l^0 = K_l^0 P_l^0(cos θ)`, where `z = cos θ`, `x = sin θ cos φ`,
//!   `y = sin θ sin φ`. Hence every low-order function is a positive
//!   multiple of its "obvious" polynomial: `Y_1,-1 ∝ +y`, `Y_1,0 ∝ +z`,
//!   `Y_1,1 ∝ +x`, `Y_2,-2 ∝ xy`, `Y_2,-1 ∝ yz`, `Y_2,0 ∝ 3z²-1`,
//!   `Y_2,1 ∝ xz`, `Y_2,2 ∝ x²-y²`.
//! * **Stored coefficients.** [`ShRgb`] stores plain radiance coefficients
//!   `L_k = ∫ L(ω) Y_k(ω) dω` — *nothing is baked in*: neither the
//!   clamped-cosine factors `A_l` nor `1/π` nor the basis constants
//!   (unlike filament, which pre-multiplies irradiance SH). Reconstruction is
//!   `L(ω) ≈ Σ_k L_k Y_k(ω)` ([`ShRgb::eval`]). Irradiance is
//!   `E(n) = Σ_k A_l(k) L_k Y_k(n)` ([`irradiance`]); the per-patch vector
//!   `A_l(k) Y_k(n)` is [`cosine_lobe_sh`], so irradiance is a dot product
//!   ([`ShRgb::dot`]). Radiosity of a Lambertian patch is then
//!   `B = ρ/π · E` (the `ρ/π` is the caller's business).
//! * **Cube map.** Faces in the order `+X, -X, +Y, -Y, +Z, -Z`, texels
//!   row-major inside a face, OpenGL cube-map orientation; see [`cubemap`].
//! * **Rotation.** Rotating a function `f` by `R` gives `g(ω) = f(R⁻¹ω)`;
//!   see [`ShRotation`].
//!
//! # Example
//!
//! ```
//! use glam::Vec3;
//! use shrad_sh::*;
//!
//! // Once: quadrature tables and projection weights.
//! let cube = CubeMap::new(16);
//! let proj = ShProjector::new(DEFAULT_BANDS, &cube);
//! // Per probe: per-texel radiance, e.g. from hit ids and a radiosity table.
//! let palette = [Vec3::ONE, Vec3::ZERO];
//! let probe = proj.project_indexed(|t| palette[usize::from(cube.directions[t].z < 0.0)]);
//! // Per patch, once: the clamped-cosine lobe (9 floats suffice, A_3 = 0).
//! let mut lobe = [0.0f32; 9];
//! cosine_lobe_sh(3, Vec3::Z, &mut lobe);
//! // Per patch, per frame: trilinear interpolation of 8 probes, then a dot.
//! let probes = [&probe; 8];
//! let mut interp = ShRgb::zeros(DEFAULT_BANDS);
//! ShRgb::lerp8_into(&probes, &trilinear_weights(Vec3::splat(0.5)), &mut interp);
//! let e = irradiance_from_lobe(&interp, &lobe);
//! // Upper hemisphere lit with L = 1: E = π (up to SH truncation).
//! assert!((e.x - std::f32::consts::PI).abs() < 0.2);
//! ```

mod basis;
mod convolve;
pub mod cubemap;
mod projector;
mod rotation;
mod shrgb;

pub use basis::{eval_basis, eval_basis_4, eval_basis_general, eval_basis_reference};
pub use convolve::{
    apply_window, convolve_cosine, cosine_lobe, cosine_lobe_sh, irradiance, irradiance_from_lobe,
    window_factor, Window,
};
pub use cubemap::{CubeFace, CubeMap};
pub use projector::ShProjector;
pub use rotation::ShRotation;
pub use shrgb::{trilinear_weights, ShRgb};

/// Largest supported number of bands (degrees `0..=7`, 64 coefficients).
pub const MAX_BANDS: usize = 8;

/// Default number of bands used by shrad (degrees `0..=3`, 16 coefficients).
pub const DEFAULT_BANDS: usize = 4;

/// Maximum number of coefficients, `MAX_BANDS²`.
pub const MAX_COEFFS: usize = MAX_BANDS * MAX_BANDS;

/// Index of coefficient `(l, m)` in a coefficient vector: `l(l+1) + m`.
///
/// Requires `-l ≤ m ≤ l` (checked in debug builds).
#[inline(always)]
pub const fn sh_index(l: usize, m: isize) -> usize {
    debug_assert!(m.unsigned_abs() <= l);
    ((l * (l + 1)) as isize + m) as usize
}

/// Number of coefficients for `bands` bands: `bands²`.
#[inline(always)]
pub const fn num_coeffs(bands: usize) -> usize {
    bands * bands
}

/// Degree `l` of the coefficient stored at `index` (`⌊√index⌋`).
#[inline]
pub const fn band_of(index: usize) -> usize {
    let mut l = 0;
    while (l + 1) * (l + 1) <= index {
        l += 1;
    }
    l
}

/// Number of bands of a coefficient vector of length `len`, if `len` is a
/// perfect square `n²` with `1 ≤ n ≤ MAX_BANDS`.
pub const fn bands_for_len(len: usize) -> Option<usize> {
    let l = band_of(len);
    if l * l == len && l >= 1 && l <= MAX_BANDS {
        Some(l)
    } else {
        None
    }
}

/// Compile-time square root (Newton iteration in `f64`), used to build the
/// basis constants without hand-typed digits.
pub(crate) const fn const_sqrt(x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let mut g = if x > 1.0 { x } else { 1.0 };
    let mut i = 0;
    while i < 200 {
        let n = 0.5 * (g + x / g);
        if n >= g {
            break;
        }
        g = n;
        i += 1;
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_helpers() {
        assert_eq!(sh_index(0, 0), 0);
        assert_eq!(sh_index(1, -1), 1);
        assert_eq!(sh_index(1, 0), 2);
        assert_eq!(sh_index(1, 1), 3);
        assert_eq!(sh_index(3, 3), 15);
        assert_eq!(sh_index(7, 7), 63);
        for l in 0..MAX_BANDS {
            for m in -(l as isize)..=(l as isize) {
                assert_eq!(band_of(sh_index(l, m)), l);
            }
        }
        assert_eq!(bands_for_len(16), Some(4));
        assert_eq!(bands_for_len(15), None);
        assert_eq!(bands_for_len(0), None);
        assert_eq!(bands_for_len(81), None);
    }

    #[test]
    fn const_sqrt_accuracy() {
        for &x in &[1e-6, 0.25, 1.0, 2.0, 3.0, 1e6, 12345.678] {
            assert!((const_sqrt(x) - x.sqrt()).abs() <= 1e-15 * x.sqrt().max(1.0));
        }
    }
}
