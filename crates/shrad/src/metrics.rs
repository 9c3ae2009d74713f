//! The error metric of spec section 8: area-weighted relative L2 error of radiosity against
//! the reference, over all patches that are not lights, per role and overall.

use glam::Vec3;
use shrad_scene::Role;

use crate::Patches;

/// Relative L2 errors (fractions, not percent). `NaN` where a role has no patches or no
/// light.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RelativeError {
    /// Over boundary and interior patches.
    pub overall: f64,
    /// Boundary patches only.
    pub boundary: f64,
    /// Interior patches only.
    pub interior: f64,
}

/// `sqrt( sum A |B - Bref|^2 / sum A |Bref|^2 )` over non-light patches, per role.
pub fn relative_error(patches: &Patches, radiosity: &[Vec3], reference: &[Vec3]) -> RelativeError {
    let mut num = [0f64; 2];
    let mut den = [0f64; 2];
    for i in 0..patches.len() {
        let k = match patches.role(i) {
            Role::Boundary => 0,
            Role::Interior => 1,
            Role::Light => continue,
        };
        let a = patches.area[i] as f64;
        // In f64: a radiosity of 1e20 (the most a solve holds) squares past f32's range.
        num[k] += a * (radiosity[i] - reference[i]).as_dvec3().length_squared();
        den[k] += a * reference[i].as_dvec3().length_squared();
    }
    let ratio = |n: f64, d: f64| if d > 0.0 { (n / d).sqrt() } else { f64::NAN };
    RelativeError {
        overall: ratio(num[0] + num[1], den[0] + den[1]),
        boundary: ratio(num[0], den[0]),
        interior: ratio(num[1], den[1]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the brightest radiosity a solve holds (1e20) the error is finite: its squares
    /// (1e40) overflowed 32-bit floats and it was NaN.
    #[test]
    fn the_error_of_the_brightest_light_is_finite() {
        let scene = shrad_scene::cornell_box();
        let patches = Patches::build(&scene, crate::PatchSizing::Count(300));
        let reference = vec![Vec3::splat(1e20); patches.len()];
        let radiosity = vec![Vec3::splat(1.1e20); patches.len()];
        let e = relative_error(&patches, &radiosity, &reference);
        for x in [e.overall, e.boundary, e.interior] {
            assert!((x - 0.1).abs() < 1e-6, "{e:?}");
        }
    }
}
