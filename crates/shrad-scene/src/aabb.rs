//! [`Aabb`]: the one axis-aligned box of shrad (scene bounds, probe boxes, the boxes a moving
//! object sweeps), instead of `(min, max)` pairs.

use glam::{Affine3A, Vec3};

/// An axis-aligned box, `min <= max` on every axis once it holds a point. [`Aabb::EMPTY`]
/// (`min = +inf`, `max = -inf`) holds none and is the identity of [`Aabb::union`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The box with no point.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// The box from `min` to `max`.
    pub const fn new(min: Vec3, max: Vec3) -> Aabb {
        Aabb { min, max }
    }

    /// The smallest box holding `points`; `None` for none.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Option<Aabb> {
        let mut it = points.into_iter();
        let first = it.next()?;
        Some(it.fold(Aabb::new(first, first), Aabb::grow))
    }

    /// Whether it holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// This box grown to hold `p`.
    #[must_use]
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb::new(self.min.min(p), self.max.max(p))
    }

    /// The smallest box holding both.
    #[must_use]
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb::new(self.min.min(other.min), self.max.max(other.max))
    }

    /// This box with `pad` added on every side.
    #[must_use]
    pub fn padded(self, pad: Vec3) -> Aabb {
        Aabb::new(self.min - pad, self.max + pad)
    }

    /// Its centre.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// `max - min`.
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Length of its diagonal.
    pub fn diagonal(&self) -> f32 {
        self.size().length()
    }

    /// Corner `c` (0..8): bit 0 picks x, bit 1 y, bit 2 z (0 = min, 1 = max).
    pub fn corner(&self, c: usize) -> Vec3 {
        let s = Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
        self.min + self.size() * s
    }

    /// The box of its 8 corners under `m` (holds the transformed box).
    #[must_use]
    pub fn transformed(&self, m: Affine3A) -> Aabb {
        (0..8)
            .map(|c| m.transform_point3(self.corner(c)))
            .fold(Aabb::EMPTY, Aabb::grow)
    }

    /// Its bounding sphere `(centre, radius)`.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        (self.centre(), 0.5 * self.diagonal())
    }

    /// Whether `p` lies inside (or on) it.
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Whether it and `other` share a point.
    pub fn meets_box(&self, other: &Aabb) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    /// Slab test: does the ray `o + t d`, `t >= 0`, meet it?
    pub fn meets_ray(&self, o: Vec3, d: Vec3) -> bool {
        let inv = d.recip();
        let t0 = (self.min - o) * inv;
        let t1 = (self.max - o) * inv;
        let near = t0.min(t1).max_element();
        let far = t0.max(t1).min_element();
        far >= near.max(0.0)
    }

    /// Slab test: does the segment from `a` to `b` meet it? (An axis along which the segment
    /// does not move constrains nothing in the slab arithmetic, `0 * inf` being NaN, which
    /// `min`/`max` skip; it is tested on its own.)
    pub fn meets_segment(&self, a: Vec3, b: Vec3) -> bool {
        self.meets_ray_within(a, b - a, 1.0)
    }

    /// Slab test: does `o + t d`, `0 <= t <= t_max`, meet it? `t_max` may be infinite.
    pub fn meets_ray_within(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        // A coordinate that does not move must lie within its slab.
        let still = d.cmpeq(Vec3::ZERO);
        if (still & (o.cmplt(self.min) | o.cmpgt(self.max))).any() {
            return false;
        }
        let inv = d.recip();
        let t0 = (self.min - o) * inv;
        let t1 = (self.max - o) * inv;
        let lo = Vec3::select(still, Vec3::NEG_INFINITY, t0.min(t1));
        let hi = Vec3::select(still, Vec3::INFINITY, t0.max(t1));
        let near = lo.max_element().max(0.0);
        let far = hi.min_element().min(t_max);
        far >= near
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_hold_what_they_should() {
        let b = Aabb::from_points([Vec3::ZERO, Vec3::new(2.0, -1.0, 4.0)]).unwrap();
        assert_eq!(
            b,
            Aabb::new(Vec3::new(0.0, -1.0, 0.0), Vec3::new(2.0, 0.0, 4.0))
        );
        assert_eq!(b.centre(), Vec3::new(1.0, -0.5, 2.0));
        assert!(b.contains(b.corner(5)) && !b.contains(Vec3::splat(5.0)));
        assert!(Aabb::EMPTY.is_empty() && !b.is_empty());
        assert_eq!(Aabb::EMPTY.union(b), b);
        assert!(Aabb::from_points([]).is_none());
        // A quarter turn about z keeps the box's size, with x and y swapped.
        let turned = b.transformed(Affine3A::from_rotation_z(std::f32::consts::FRAC_PI_2));
        assert!(
            (turned.size() - Vec3::new(1.0, 2.0, 4.0))
                .abs()
                .max_element()
                < 1e-5
        );
        let (c, r) = b.bounding_sphere();
        assert!((r - 0.5 * 21f32.sqrt()).abs() < 1e-6 && c == b.centre());
        assert!(b.meets_ray(Vec3::new(1.0, -0.5, -3.0), Vec3::Z));
        assert!(!b.meets_ray(Vec3::new(1.0, -0.5, -3.0), -Vec3::Z));
        assert!(!b.meets_ray(Vec3::new(5.0, -0.5, -3.0), Vec3::Z));
        // Segments: one that stops short, one that reaches in, one along a face, one inside.
        let o = Vec3::new(1.0, -0.5, -3.0);
        assert!(!b.meets_segment(o, Vec3::new(1.0, -0.5, -0.5)));
        assert!(b.meets_segment(o, Vec3::new(1.0, -0.5, 0.5)));
        assert!(b.meets_segment(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0)));
        assert!(!b.meets_segment(Vec3::new(-0.1, 0.0, -1.0), Vec3::new(-0.1, 0.0, 1.0)));
        assert!(b.meets_segment(b.centre(), b.centre() + Vec3::X * 0.1));
        assert!(b.meets_ray_within(o, Vec3::Z, f32::INFINITY));
        // Boxes that share a corner meet; a gap along one axis parts them.
        assert!(b.meets_box(&Aabb::new(Vec3::new(2.0, 0.0, 4.0), Vec3::splat(5.0))));
        assert!(!b.meets_box(&Aabb::new(Vec3::new(2.1, 0.0, 4.0), Vec3::splat(5.0))));
        assert!(!b.meets_box(&Aabb::EMPTY));
        assert!(!b.meets_ray_within(o, Vec3::Z, 2.5));
    }
}
