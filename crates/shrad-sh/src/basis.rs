//! Evaluation of the real orthonormal SH basis (see the crate docs for the
//! normalisation and sign convention).
//!
//! Three implementations:
//! * [`eval_basis_general`] — any number of bands, by the stable recurrence
//!   on the normalised associated Legendre functions in `z` and the
//!   `cos(mφ) sinᵐθ`, `sin(mφ) sinᵐθ` terms obtained as the real and
//!   imaginary parts of `(x + iy)ᵐ` (no trigonometry, no square roots);
//! * [`eval_basis_4`] — unrolled polynomial fast path for the hot case
//!   (`bands ≤ 4`, 16 coefficients); [`eval_basis`] dispatches to it;
//! * [`eval_basis_reference`] — textbook closed forms in spherical
//!   coordinates (`acos`/`atan2`/`cos`/`sin`, factorials), for tests only.

use crate::{const_sqrt, sh_index, MAX_BANDS};
use glam::Vec3;
use std::f64::consts::PI;

/// Recurrence constants, computed at compile time.
///
/// With `N_l^m(z)` the normalised Legendre part (`Y_l^m = N_l^m(z) · C_m` for
/// `m > 0`, `· S_m` for `m < 0`, where `C_m + i S_m = (x + iy)^m`):
/// * `N_m^m = DIAG[m]` (includes the `√2` for `m > 0`);
/// * `N_l^m = A[l][m] z N_{l-1}^m - B[l][m] N_{l-2}^m` for `l > m`, with
///   `A = sqrt((4l²-1)/(l²-m²))`, `B = sqrt((2l+1)((l-1)²-m²)/((2l-3)(l²-m²)))`
///   (`B = 0` for `l = m + 1`).
struct Tables {
    a: [[f32; MAX_BANDS]; MAX_BANDS],
    b: [[f32; MAX_BANDS]; MAX_BANDS],
    diag: [f32; MAX_BANDS],
}

const fn build_tables() -> Tables {
    let mut a = [[0.0f32; MAX_BANDS]; MAX_BANDS];
    let mut b = [[0.0f32; MAX_BANDS]; MAX_BANDS];
    let mut diag = [0.0f32; MAX_BANDS];
    let mut l = 0;
    while l < MAX_BANDS {
        let mut m = 0;
        while m < l {
            let lf = l as f64;
            let mf = m as f64;
            a[l][m] = const_sqrt((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)) as f32;
            if l > m + 1 {
                b[l][m] = const_sqrt(
                    (2.0 * lf + 1.0) * ((lf - 1.0) * (lf - 1.0) - mf * mf)
                        / ((2.0 * lf - 3.0) * (lf * lf - mf * mf)),
                ) as f32;
            }
            m += 1;
        }
        l += 1;
    }
    // K_m^m (2m-1)!! = sqrt((2m+1)/(2m)) * K_{m-1}^{m-1} (2m-3)!!
    let mut d = 1.0 / const_sqrt(4.0 * PI);
    diag[0] = d as f32;
    let mut m = 1;
    while m < MAX_BANDS {
        let mf = m as f64;
        d *= const_sqrt((2.0 * mf + 1.0) / (2.0 * mf));
        diag[m] = (d * const_sqrt(2.0)) as f32;
        m += 1;
    }
    Tables { a, b, diag }
}

static TABLES: Tables = build_tables();

/// Evaluates the first `bands²` real SH basis functions at the unit
/// direction `dir` into `out[..bands²]`.
///
/// Dispatches to the unrolled [`eval_basis_4`] for `bands ≤ 4` and to
/// [`eval_basis_general`] otherwise. `dir` must be normalised (not checked).
///
/// # Panics
/// If `bands` is not in `1..=MAX_BANDS` or `out.len() < bands²`.
#[inline]
pub fn eval_basis(bands: usize, dir: Vec3, out: &mut [f32]) {
    assert!((1..=MAX_BANDS).contains(&bands), "bands out of range");
    let n = bands * bands;
    assert!(out.len() >= n, "output slice too short");
    if bands <= 4 {
        let y = eval_basis_4(dir);
        out[..n].copy_from_slice(&y[..n]);
    } else {
        eval_basis_general(bands, dir, out);
    }
}

/// General-band evaluation by recurrence (see module docs); writes
/// `out[..bands²]`. `dir` must be normalised.
///
/// # Panics
/// If `bands` is not in `1..=MAX_BANDS` or `out.len() < bands²`.
pub fn eval_basis_general(bands: usize, dir: Vec3, out: &mut [f32]) {
    assert!((1..=MAX_BANDS).contains(&bands), "bands out of range");
    assert!(out.len() >= bands * bands, "output slice too short");
    let t = &TABLES;
    let (x, y, z) = (dir.x, dir.y, dir.z);
    // C_m + i S_m = (x + i y)^m
    let mut c = 1.0f32;
    let mut s = 0.0f32;
    for m in 0..bands {
        let mut p2 = 0.0f32;
        let mut p1 = t.diag[m];
        let mut l = m;
        loop {
            let p = p1;
            if m == 0 {
                out[sh_index(l, 0)] = p;
            } else {
                out[sh_index(l, m as isize)] = p * c;
                out[sh_index(l, -(m as isize))] = p * s;
            }
            l += 1;
            if l >= bands {
                break;
            }
            let pn = t.a[l][m] * z * p1 - t.b[l][m] * p2;
            p2 = p1;
            p1 = pn;
        }
        let cn = x * c - y * s;
        s = x * s + y * c;
        c = cn;
    }
}

const K00: f32 = (0.5 / const_sqrt(PI)) as f32;
const K1: f32 = const_sqrt(3.0 / (4.0 * PI)) as f32;
const K2_XY: f32 = const_sqrt(15.0 / (4.0 * PI)) as f32;
const K2_0: f32 = const_sqrt(5.0 / (16.0 * PI)) as f32;
const K2_2: f32 = const_sqrt(15.0 / (16.0 * PI)) as f32;
const K3_3: f32 = const_sqrt(35.0 / (32.0 * PI)) as f32;
const K3_XYZ: f32 = const_sqrt(105.0 / (4.0 * PI)) as f32;
const K3_2: f32 = const_sqrt(105.0 / (16.0 * PI)) as f32;
const K3_1: f32 = const_sqrt(21.0 / (32.0 * PI)) as f32;
const K3_0: f32 = const_sqrt(7.0 / (16.0 * PI)) as f32;

/// Unrolled evaluation of the first 16 basis functions (4 bands) at the
/// unit direction `dir`. Bit-for-bit independent of, and equal within
/// rounding to, [`eval_basis_general`].
#[inline]
pub fn eval_basis_4(dir: Vec3) -> [f32; 16] {
    let (x, y, z) = (dir.x, dir.y, dir.z);
    let x2 = x * x;
    let y2 = y * y;
    let z2 = z * z;
    let five_z2_m1 = 5.0 * z2 - 1.0;
    [
        K00,
        K1 * y,
        K1 * z,
        K1 * x,
        K2_XY * x * y,
        K2_XY * y * z,
        K2_0 * (3.0 * z2 - 1.0),
        K2_XY * x * z,
        K2_2 * (x2 - y2),
        K3_3 * y * (3.0 * x2 - y2),
        K3_XYZ * x * y * z,
        K3_1 * y * five_z2_m1,
        K3_0 * z * (5.0 * z2 - 3.0),
        K3_1 * x * five_z2_m1,
        K3_2 * z * (x2 - y2),
        K3_3 * x * (x2 - 3.0 * y2),
    ]
}

/// `out[n] = Σ_k c[k] Y_k(d_n)` over the 16 functions of 4 bands, for the directions
/// `d_n = (x[n], y[n], z[n])`: the floats of [`eval_basis_4`] followed by a dot product in
/// `k` order (as `ShRgb::eval` computes them), but one function at a time over a run of
/// directions, which vectorises.
pub(crate) fn dot_basis_4_many(c: &[Vec3; 16], x: &[f32], y: &[f32], z: &[f32], out: &mut [Vec3]) {
    const L: usize = 16;
    let chunks = out
        .chunks_mut(L)
        .zip(x.chunks(L))
        .zip(y.chunks(L))
        .zip(z.chunks(L));
    for (((out, xs), ys), zs) in chunks {
        let m = out.len().min(xs.len()).min(ys.len()).min(zs.len());
        // Fixed-length lanes (a short last chunk padded with zeros): loops of a known
        // length vectorise fully.
        let lanes = |v: &[f32]| {
            let mut a = [0f32; L];
            a[..m].copy_from_slice(&v[..m]);
            a
        };
        let (xs, ys, zs) = (lanes(xs), lanes(ys), lanes(zs));
        let (mut r, mut g, mut b) = ([0f32; L], [0f32; L], [0f32; L]);
        macro_rules! term {
            ($k:expr, |$x:ident, $y:ident, $z:ident| $e:expr) => {
                let ck = c[$k];
                for i in 0..L {
                    let ($x, $y, $z) = (xs[i], ys[i], zs[i]);
                    let v: f32 = $e;
                    r[i] += ck.x * v;
                    g[i] += ck.y * v;
                    b[i] += ck.z * v;
                }
            };
        }
        // The expressions of `eval_basis_4`, in its order and association.
        term!(0, |_x, _y, _z| K00);
        term!(1, |_x, y, _z| K1 * y);
        term!(2, |_x, _y, z| K1 * z);
        term!(3, |x, _y, _z| K1 * x);
        term!(4, |x, y, _z| K2_XY * x * y);
        term!(5, |_x, y, z| K2_XY * y * z);
        term!(6, |_x, _y, z| K2_0 * (3.0 * (z * z) - 1.0));
        term!(7, |x, _y, z| K2_XY * x * z);
        term!(8, |x, y, _z| K2_2 * (x * x - y * y));
        term!(9, |x, y, _z| K3_3 * y * (3.0 * (x * x) - y * y));
        term!(10, |x, y, z| K3_XYZ * x * y * z);
        term!(11, |_x, y, z| K3_1 * y * (5.0 * (z * z) - 1.0));
        term!(12, |_x, _y, z| K3_0 * z * (5.0 * (z * z) - 3.0));
        term!(13, |x, _y, z| K3_1 * x * (5.0 * (z * z) - 1.0));
        term!(14, |x, y, z| K3_2 * z * (x * x - y * y));
        term!(15, |x, y, _z| K3_3 * x * (x * x - 3.0 * (y * y)));
        for (i, o) in out.iter_mut().enumerate().take(m) {
            *o = Vec3::new(r[i], g[i], b[i]);
        }
    }
}

/// Textbook closed-form reference for `bands ≤ 4`, computed in `f64` from
/// spherical coordinates `θ = acos z`, `φ = atan2(y, x)`, explicit
/// associated Legendre polynomials (no Condon–Shortley phase) and factorial
/// normalisation `K_l^m`. Slow; meant for tests. Writes `out[..bands²]`.
///
/// # Panics
/// If `bands` is not in `1..=4` or `out.len() < bands²`.
pub fn eval_basis_reference(bands: usize, dir: Vec3, out: &mut [f32]) {
    assert!((1..=4).contains(&bands), "reference supports 1..=4 bands");
    assert!(out.len() >= bands * bands, "output slice too short");
    let d = dir.as_dvec3().normalize();
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.y.atan2(d.x);
    let (st, ct) = theta.sin_cos();
    let fact = |n: usize| -> f64 { (1..=n).map(|i| i as f64).product() };
    // P_l^m(cos θ), m ≥ 0, without the (-1)^m phase.
    let legendre = |l: usize, m: usize| -> f64 {
        match (l, m) {
            (0, 0) => 1.0,
            (1, 0) => ct,
            (1, 1) => st,
            (2, 0) => 0.5 * (3.0 * ct * ct - 1.0),
            (2, 1) => 3.0 * ct * st,
            (2, 2) => 3.0 * st * st,
            (3, 0) => 0.5 * (5.0 * ct * ct * ct - 3.0 * ct),
            (3, 1) => 1.5 * (5.0 * ct * ct - 1.0) * st,
            (3, 2) => 15.0 * ct * st * st,
            (3, 3) => 15.0 * st * st * st,
            _ => unreachable!(),
        }
    };
    for l in 0..bands {
        for m in -(l as isize)..=(l as isize) {
            let am = m.unsigned_abs();
            let k = ((2 * l + 1) as f64 / (4.0 * PI) * fact(l - am) / fact(l + am)).sqrt();
            let p = legendre(l, am);
            let v = match m {
                0 => k * p,
                m if m > 0 => 2f64.sqrt() * k * (m as f64 * phi).cos() * p,
                _ => 2f64.sqrt() * k * (am as f64 * phi).sin() * p,
            };
            out[sh_index(l, m)] = v as f32;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Small deterministic PRNG (xorshift64*) for tests.
    pub(crate) struct Rng(u64);
    impl Rng {
        pub(crate) fn new(seed: u64) -> Self {
            Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
        }
        pub(crate) fn next_u64(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }
        /// Uniform in [0, 1).
        pub(crate) fn f32(&mut self) -> f32 {
            (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
        }
        /// Uniform in [-1, 1).
        pub(crate) fn sym(&mut self) -> f32 {
            2.0 * self.f32() - 1.0
        }
        /// Uniform unit vector.
        pub(crate) fn dir(&mut self) -> Vec3 {
            loop {
                let v = Vec3::new(self.sym(), self.sym(), self.sym());
                let l2 = v.length_squared();
                if l2 > 1e-4 && l2 <= 1.0 {
                    return v / l2.sqrt();
                }
            }
        }
    }

    #[test]
    fn fast_general_reference_agree() {
        let mut rng = Rng::new(1);
        let mut dirs: Vec<Vec3> = (0..2000).map(|_| rng.dir()).collect();
        dirs.extend([Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]);
        for d in dirs {
            let fast = eval_basis_4(d);
            let mut gen = [0.0f32; 16];
            eval_basis_general(4, d, &mut gen);
            let mut reference = [0.0f32; 16];
            eval_basis_reference(4, d, &mut reference);
            for k in 0..16 {
                assert!((fast[k] - gen[k]).abs() < 2e-6, "fast/general k={k} d={d}");
                assert!(
                    (fast[k] - reference[k]).abs() < 2e-6,
                    "fast/reference k={k} d={d}: {} vs {}",
                    fast[k],
                    reference[k]
                );
            }
            // Dispatch and lower band counts are prefixes.
            for bands in 1..=4 {
                let mut o = [0.0f32; 16];
                eval_basis(bands, d, &mut o);
                assert_eq!(&o[..bands * bands], &fast[..bands * bands]);
                let mut g = [0.0f32; 16];
                eval_basis_general(bands, d, &mut g);
                for k in 0..bands * bands {
                    assert!((g[k] - fast[k]).abs() < 2e-6);
                }
            }
            // Higher band counts extend lower ones.
            let mut g8 = [0.0f32; 64];
            eval_basis(8, d, &mut g8);
            for k in 0..16 {
                assert!((g8[k] - fast[k]).abs() < 2e-6);
            }
        }
    }

    #[test]
    fn sign_convention() {
        let mut y = [0.0f32; 16];
        eval_basis(4, Vec3::Y, &mut y);
        assert!(y[sh_index(1, -1)] > 0.0);
        eval_basis(4, Vec3::Z, &mut y);
        assert!(y[sh_index(1, 0)] > 0.0);
        eval_basis(4, Vec3::X, &mut y);
        assert!(y[sh_index(1, 1)] > 0.0);
        assert!(y[sh_index(2, 2)] > 0.0);
        assert!(y[sh_index(3, 3)] > 0.0);
        assert!((y[0] - 0.282_094_8).abs() < 1e-7);
    }

    #[test]
    fn addition_theorem_high_bands() {
        // Σ_m Y_lm(ω)² = (2l+1)/(4π) for every ω, independent of the basis
        // details: checks the general recurrence up to 8 bands.
        let mut rng = Rng::new(7);
        let mut y = [0.0f32; 64];
        for _ in 0..500 {
            let d = rng.dir();
            eval_basis(8, d, &mut y);
            for l in 0..8 {
                let s: f64 = (0..2 * l + 1).map(|i| (y[l * l + i] as f64).powi(2)).sum();
                let want = (2 * l + 1) as f64 / (4.0 * PI);
                assert!((s - want).abs() < 1e-5 * want, "l={l}: {s} vs {want}");
            }
        }
    }
}
