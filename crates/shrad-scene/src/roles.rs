//! Role inference for imported meshes that carry none (spec section 3).

use crate::{Role, Scene};

/// Give every object without a role one: emissive objects are lights; an object whose
/// bounding box touches the scene's box and spans at least half of it on two axes is
/// boundary (a wall, floor or ceiling); the rest are interior. Returns how many were inferred.
pub fn infer_roles(scene: &mut Scene) -> usize {
    let Some(crate::Aabb { min: lo, max: hi }) = scene.bounds() else {
        return 0;
    };
    let ext = (hi - lo).max(glam::Vec3::splat(f32::MIN_POSITIVE));
    let touch = 0.01 * ext.length();
    let mut inferred = 0;
    for o in &mut scene.objects {
        if o.role.is_some() {
            continue;
        }
        inferred += 1;
        if o.material.is_emissive() {
            o.role = Some(Role::Light);
            continue;
        }
        let Some(crate::Aabb { min: olo, max: ohi }) = o.world_bounds() else {
            o.role = Some(Role::Interior);
            continue;
        };
        let touches = (olo - lo).min_element() <= touch || (hi - ohi).min_element() <= touch;
        let span = (ohi - olo) / ext;
        let wide_axes = span.to_array().iter().filter(|&&s| s >= 0.5).count();
        o.role = Some(if touches && wide_axes >= 2 {
            Role::Boundary
        } else {
            Role::Interior
        });
    }
    inferred
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cornell_roles_inferred_as_given() {
        let given = crate::cornell_box();
        let mut stripped = given.clone();
        for o in &mut stripped.objects {
            o.role = None;
        }
        infer_roles(&mut stripped);
        for (a, b) in given.objects.iter().zip(&stripped.objects) {
            assert_eq!(a.role, b.role, "object {}", a.name);
        }
    }
}
