//! A punctual light inside a closed, single-sided object whose faces all look away from it (a
//! lamp left inside a box, a room modelled with its normals outwards) lights none of that
//! object's faces and nothing beyond them; what the solvers then show is a leak through the
//! patches that cross the surface, blotches at any exposure. Found at load by the object's
//! winding number at the light, and said as a warning.

use glam::{DVec3, Vec3};

use crate::{LightKind, Object, Scene};

/// How close to a whole turn the winding number must be for the light to count as enclosed:
/// a closed mesh gives 1 to rounding; a shade open at one end, whose light gets out, less.
const ENCLOSED: f64 = 0.95;

impl Scene {
    /// Warn of every point or spot light that stands, at rest, inside a closed single-sided
    /// object facing away from it. (Double-sided objects are left out: a room made from a
    /// cube, normals outwards, is lit on its inside.)
    pub(crate) fn warn_enclosed_lights(&mut self) {
        for l in &self.lights {
            if l.kind == LightKind::Directional {
                continue;
            }
            let at = crate::Light::position(&l.world_from_light);
            let enclosing = self.objects.iter().find(|o| {
                !o.material.double_sided && super::holds(o, at) && winding_number(o, at) > ENCLOSED
            });
            if let Some(o) = enclosing {
                self.warnings.push(format!(
                    "light '{}' is inside object '{}', a closed surface whose faces all look \
                     away from it: it lights none of them, and what reaches the rest of the \
                     scene is a leak through patches that cross that surface (move the \
                     light, or turn the object's faces)",
                    l.name, o.name
                ));
            }
        }
    }
}

/// The generalised winding number of object `o`'s surface at `p` (world): the solid angle its
/// triangles subtend from `p`, each signed by the side it turns to `p`, over 4 pi. It is 1
/// inside a closed surface whose fronts face outwards, -1 inside one facing inwards, 0
/// outside either, and a fraction for a surface with holes (Jacobson et al. 2013). A mirroring
/// transform turns which side is the front (`Mesh::triangles`), so it turns the sign back.
pub(crate) fn winding_number(o: &Object, p: Vec3) -> f64 {
    let m = o.world_from_object;
    let side = f64::from(m.matrix3.determinant().signum());
    let p = p.as_dvec3();
    let corner = |i: u32| m.transform_point3(o.mesh.positions[i as usize]).as_dvec3() - p;
    let turn: f64 = (o.mesh.triangles.iter())
        .map(|t| solid_angle(t.map(corner)))
        .sum();
    side * turn / (4.0 * std::f64::consts::PI)
}

/// The signed solid angle of the triangle with corners `a, b, c` (relative to the eye),
/// positive when the eye is behind it (the corners counter-clockwise seen from its front):
/// Van Oosterom and Strackee's formula.
fn solid_angle([a, b, c]: [DVec3; 3]) -> f64 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let div = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * det.atan2(div)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Material, Mesh};
    use glam::Affine3A;

    /// A unit cube about the origin, fronts outwards.
    fn cube() -> Object {
        let positions: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32) - 0.5)
            .collect();
        // Each face as two counter-clockwise triangles seen from outside.
        let quads = [
            [0, 2, 3, 1], // -z
            [4, 5, 7, 6], // +z
            [0, 1, 5, 4], // -y
            [2, 6, 7, 3], // +y
            [0, 4, 6, 2], // -x
            [1, 3, 7, 5], // +x
        ];
        let triangles = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect();
        let mesh = Mesh {
            positions,
            triangles,
            ..Default::default()
        };
        Object::new("cube", mesh, Material::default())
    }

    #[test]
    fn winding_number_is_one_inside_zero_outside_and_turns_with_the_faces() {
        let mut o = cube();
        // Every face's front looks outwards (the check of the fixture itself).
        for t in &o.mesh.triangles {
            let [a, b, c] = t.map(|i| o.mesh.positions[i as usize]);
            assert!((b - a).cross(c - a).dot((a + b + c) / 3.0) > 0.0);
        }
        for p in [Vec3::ZERO, Vec3::new(0.3, -0.2, 0.45)] {
            assert!((winding_number(&o, p) - 1.0).abs() < 1e-9, "{p}");
        }
        assert!(winding_number(&o, Vec3::new(2.0, 0.1, 0.0)).abs() < 1e-9);
        // Mirrored, the fronts still face outwards.
        o.world_from_object = Affine3A::from_scale(Vec3::new(-2.0, 1.0, 1.0));
        assert!((winding_number(&o, Vec3::new(0.9, 0.0, 0.0)) - 1.0).abs() < 1e-9);
        // Faces turned inwards (a room): -1.
        o.world_from_object = Affine3A::IDENTITY;
        o.mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert!((winding_number(&o, Vec3::ZERO) + 1.0).abs() < 1e-9);
        // One face taken off (a shade open at one end): well under a whole turn.
        o.mesh.triangles.truncate(10);
        let open = winding_number(&o, Vec3::new(0.0, 0.0, 0.0)).abs();
        assert!((0.5..ENCLOSED).contains(&open), "{open}");
    }
}
