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
        num[k] += a * (radiosity[i] - reference[i]).length_squared() as f64;
        den[k] += a * reference[i].length_squared() as f64;
    }
    let ratio = |n: f64, d: f64| if d > 0.0 { (n / d).sqrt() } else { f64::NAN };
    RelativeError {
        overall: ratio(num[0] + num[1], den[0] + den[1]),
        boundary: ratio(num[0], den[0]),
        interior: ratio(num[1], den[1]),
    }
}
