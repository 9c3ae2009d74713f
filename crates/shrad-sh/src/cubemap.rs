//! Cube-map quadrature: per-texel directions and exact solid angles.
//!
//! # Layout
//!
//! * Faces in the order `+X, -X, +Y, -Y, +Z, -Z` ([`CubeFace`], index 0..6).
//! * Inside a face, texels are row-major: texel `(row, col)` of face `f` is
//!   at index `f·res² + row·res + col`.
//! * Face coordinates of the texel centre:
//!   `u = 2(col + ½)/res − 1` (left → right), `v = 2(row + ½)/res − 1`
//!   (top → bottom), both in `(-1, 1)`.
//! * Orientation is the OpenGL / Direct3D cube-map convention (each face seen
//!   from the centre of the cube, row 0 at the top): the unnormalised
//!   direction is `major + u·u_axis + v·v_axis` with ([`CubeFace::axes`])
//!
//!   | face | major | u_axis | v_axis | direction |
//!   |------|-------|--------|--------|-----------|
//!   | +X   | +x    | −z     | −y     | `( 1, −v, −u)` |
//!   | −X   | −x    | +z     | −y     | `(−1, −v,  u)` |
//!   | +Y   | +y    | +x     | +z     | `( u,  1,  v)` |
//!   | −Y   | −y    | +x     | −z     | `( u, −1, −v)` |
//!   | +Z   | +z    | +x     | −y     | `( u, −v,  1)` |
//!   | −Z   | −z    | −x     | −y     | `(−u, −v, −1)` |
//!
//! A rasteriser rendering face `f` should use a 90° frustum looking along
//! `major`, with image-right = `u_axis` and image-down = `v_axis`.
//!
//! # Solid angle
//!
//! The solid angle of the rectangle `[x0,x1]×[y0,y1]` on the plane at unit
//! distance is `F(x0,y0) − F(x0,y1) − F(x1,y0) + F(x1,y1)` with
//! `F(x,y) = atan2(xy, sqrt(x²+y²+1))`; it is evaluated in `f64` so that the
//! 6·res² values sum to `4π` to `f32` precision.

use glam::{DVec3, Vec3};

/// A cube-map face; the discriminant is the face index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CubeFace {
    /// Face looking along +X (index 0).
    PosX = 0,
    /// Face looking along −X (index 1).
    NegX = 1,
    /// Face looking along +Y (index 2).
    PosY = 2,
    /// Face looking along −Y (index 3).
    NegY = 3,
    /// Face looking along +Z (index 4).
    PosZ = 4,
    /// Face looking along −Z (index 5).
    NegZ = 5,
}

impl CubeFace {
    /// All faces in storage order.
    pub const ALL: [CubeFace; 6] = [
        CubeFace::PosX,
        CubeFace::NegX,
        CubeFace::PosY,
        CubeFace::NegY,
        CubeFace::PosZ,
        CubeFace::NegZ,
    ];

    /// Face index in storage order (`0..6`).
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    /// `(major, u_axis, v_axis)`: the texel at face coordinates `(u, v)`
    /// looks along `major + u·u_axis + v·v_axis` (see the module table).
    #[inline]
    pub fn axes(self) -> (Vec3, Vec3, Vec3) {
        match self {
            CubeFace::PosX => (Vec3::X, -Vec3::Z, -Vec3::Y),
            CubeFace::NegX => (-Vec3::X, Vec3::Z, -Vec3::Y),
            CubeFace::PosY => (Vec3::Y, Vec3::X, Vec3::Z),
            CubeFace::NegY => (-Vec3::Y, Vec3::X, -Vec3::Z),
            CubeFace::PosZ => (Vec3::Z, Vec3::X, -Vec3::Y),
            CubeFace::NegZ => (-Vec3::Z, -Vec3::X, -Vec3::Y),
        }
    }
}

/// Per-texel directions and solid angles of a cube map of `res × res`
/// texels per face (structure of arrays, `6·res²` entries each, layout in
/// the module docs).
#[derive(Clone, Debug)]
pub struct CubeMap {
    res: usize,
    /// Unit direction through each texel centre.
    pub directions: Vec<Vec3>,
    /// Exact solid angle of each texel (steradians); they sum to `4π`.
    pub solid_angles: Vec<f32>,
}

#[inline]
fn area_element(x: f64, y: f64) -> f64 {
    (x * y).atan2((x * x + y * y + 1.0).sqrt())
}

/// Exact solid angle of the texel `(row, col)` of a `res × res` face.
pub fn texel_solid_angle(res: usize, row: usize, col: usize) -> f64 {
    let inv = 2.0 / res as f64;
    let x0 = col as f64 * inv - 1.0;
    let x1 = (col + 1) as f64 * inv - 1.0;
    let y0 = row as f64 * inv - 1.0;
    let y1 = (row + 1) as f64 * inv - 1.0;
    area_element(x0, y0) - area_element(x0, y1) - area_element(x1, y0) + area_element(x1, y1)
}

impl CubeMap {
    /// Builds the tables for `res × res` texels per face.
    ///
    /// # Panics
    /// If `res == 0`.
    pub fn new(res: usize) -> Self {
        assert!(res > 0, "cube map resolution must be positive");
        let per_face = res * res;
        // Solid angles are identical on every face (same (u, v) grid).
        let mut face_sa = Vec::with_capacity(per_face);
        for row in 0..res {
            for col in 0..res {
                face_sa.push(texel_solid_angle(res, row, col) as f32);
            }
        }
        let mut directions = Vec::with_capacity(6 * per_face);
        let mut solid_angles = Vec::with_capacity(6 * per_face);
        for face in CubeFace::ALL {
            let (major, ua, va) = face.axes();
            let (major, ua, va) = (major.as_dvec3(), ua.as_dvec3(), va.as_dvec3());
            for row in 0..res {
                let v = (2 * row + 1) as f64 / res as f64 - 1.0;
                for col in 0..res {
                    let u = (2 * col + 1) as f64 / res as f64 - 1.0;
                    let d: DVec3 = major + u * ua + v * va;
                    directions.push(d.normalize().as_vec3());
                }
            }
            solid_angles.extend_from_slice(&face_sa);
        }
        CubeMap {
            res,
            directions,
            solid_angles,
        }
    }

    /// Texels per face edge.
    #[inline]
    pub fn res(&self) -> usize {
        self.res
    }

    /// Total texel count, `6·res²`.
    #[inline]
    pub fn len(&self) -> usize {
        self.directions.len()
    }

    /// Always `false` (a cube map has at least 6 texels).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.directions.is_empty()
    }

    /// Storage index of texel `(row, col)` of `face`.
    #[inline]
    pub fn texel_index(&self, face: CubeFace, row: usize, col: usize) -> usize {
        (face.index() * self.res + row) * self.res + col
    }

    /// `(face, row, col)` of a storage index.
    #[inline]
    pub fn texel_coords(&self, index: usize) -> (CubeFace, usize, usize) {
        let per_face = self.res * self.res;
        let f = index / per_face;
        let r = index % per_face;
        (CubeFace::ALL[f], r / self.res, r % self.res)
    }

    /// Index of the texel containing direction `dir` (need not be
    /// normalised, must be non-zero). Ties on cube edges go to the first
    /// face in `X, Y, Z` order with the largest magnitude.
    #[inline]
    pub fn texel_of(&self, dir: Vec3) -> usize {
        let a = dir.abs();
        let (face, ma) = if a.x >= a.y && a.x >= a.z {
            (
                if dir.x >= 0.0 {
                    CubeFace::PosX
                } else {
                    CubeFace::NegX
                },
                a.x,
            )
        } else if a.y >= a.z {
            (
                if dir.y >= 0.0 {
                    CubeFace::PosY
                } else {
                    CubeFace::NegY
                },
                a.y,
            )
        } else {
            (
                if dir.z >= 0.0 {
                    CubeFace::PosZ
                } else {
                    CubeFace::NegZ
                },
                a.z,
            )
        };
        let (_, ua, va) = face.axes();
        let inv = 1.0 / ma;
        let u = dir.dot(ua) * inv;
        let v = dir.dot(va) * inv;
        let res = self.res as f32;
        let col = (((u + 1.0) * 0.5 * res) as isize).clamp(0, self.res as isize - 1) as usize;
        let row = (((v + 1.0) * 0.5 * res) as isize).clamp(0, self.res as isize - 1) as usize;
        self.texel_index(face, row, col)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tests::Rng;
    use std::f64::consts::PI;

    #[test]
    fn solid_angles_sum_to_4pi() {
        for res in [1usize, 2, 8, 33, 128] {
            let cm = CubeMap::new(res);
            assert_eq!(cm.len(), 6 * res * res);
            assert!(cm.solid_angles.iter().all(|&w| w > 0.0));
            let sum: f64 = cm.solid_angles.iter().map(|&w| w as f64).sum();
            let rel = (sum - 4.0 * PI).abs() / (4.0 * PI);
            assert!(rel < 1e-5, "res {res}: sum {sum}, rel err {rel}");
        }
        // res = 1: each face is exactly 4π/6.
        let cm = CubeMap::new(1);
        for &w in &cm.solid_angles {
            assert!((w as f64 - 4.0 * PI / 6.0).abs() < 1e-6);
        }
    }

    #[test]
    fn directions_unit_and_face_orientation() {
        let cm = CubeMap::new(4);
        for d in &cm.directions {
            assert!((d.length() - 1.0).abs() < 1e-6);
        }
        // Top-left texel of +X looks to (+1, +y, +z); of +Z to (-x, +y, +1).
        let d = cm.directions[cm.texel_index(CubeFace::PosX, 0, 0)];
        assert!(d.x > 0.0 && d.y > 0.0 && d.z > 0.0);
        let d = cm.directions[cm.texel_index(CubeFace::PosZ, 0, 0)];
        assert!(d.x < 0.0 && d.y > 0.0 && d.z > 0.0);
        let d = cm.directions[cm.texel_index(CubeFace::PosY, 0, 0)];
        assert!(d.x < 0.0 && d.y > 0.0 && d.z < 0.0);
        // Each face's axes form a frame with u × v = ±major consistently
        // (OpenGL faces are all left-handed seen from inside: u × v = -major).
        for f in CubeFace::ALL {
            let (m, u, v) = f.axes();
            assert!((u.cross(v) + m).length() < 1e-6, "{f:?}");
        }
    }

    #[test]
    fn texel_of_inverts_directions() {
        for res in [1usize, 3, 16, 64] {
            let cm = CubeMap::new(res);
            for (t, &d) in cm.directions.iter().enumerate() {
                assert_eq!(cm.texel_of(d), t, "res {res} texel {t}");
                assert_eq!(cm.texel_of(d * 3.5), t);
                let (f, r, c) = cm.texel_coords(t);
                assert_eq!(cm.texel_index(f, r, c), t);
            }
        }
        let cm = CubeMap::new(32);
        let mut rng = Rng::new(3);
        for _ in 0..1000 {
            let d = rng.dir();
            let t = cm.texel_of(d);
            // The texel centre is within half a texel diagonal of d.
            assert!(cm.directions[t].dot(d) > (2.0f32 * 2.0 / 32.0).cos());
        }
    }
}
