//! The surface attributes at a patch corner (texture coordinates, vertex colour),
//! interpolated from the source triangle's vertices.

use glam::{Vec2, Vec3};
use shrad_scene::{Mesh, Object};

/// The surface attributes at a patch corner, interpolated from the source triangle's
/// vertices: what a textured or vertex-coloured material is sampled with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerAttr {
    /// Texture coordinates: `[0]` the set the base-colour texture reads, `[1]` the set the
    /// emissive texture reads.
    pub uv: [Vec2; 2],
    /// Vertex colour (1 without `COLOR_0`).
    pub color: Vec3,
    /// The lightmap's texture coordinates (the mesh's `lightmap_uvs`, glTF `TEXCOORD_1`; 0
    /// without them).
    pub lightmap: Vec2,
}

impl Default for CornerAttr {
    fn default() -> Self {
        CornerAttr {
            uv: [Vec2::ZERO; 2],
            color: Vec3::ONE,
            lightmap: Vec2::ZERO,
        }
    }
}

impl CornerAttr {
    /// `sum w_k a_k`.
    pub fn combine<const N: usize>(terms: [(f32, CornerAttr); N]) -> CornerAttr {
        let mut r = CornerAttr {
            uv: [Vec2::ZERO; 2],
            color: Vec3::ZERO,
            lightmap: Vec2::ZERO,
        };
        for (w, a) in terms {
            r.uv[0] += w * a.uv[0];
            r.uv[1] += w * a.uv[1];
            r.color += w * a.color;
            r.lightmap += w * a.lightmap;
        }
        r
    }
    /// The attributes at `(s, t)` of a parallelogram with these corners (bilinear; affine
    /// when the corners are, as `split::pair_parallelograms` makes sure).
    pub fn bilinear(c: &[CornerAttr; 4], s: f32, t: f32) -> CornerAttr {
        CornerAttr::combine([
            ((1.0 - s) * (1.0 - t), c[0]),
            (s * (1.0 - t), c[1]),
            (s * t, c[2]),
            ((1.0 - s) * t, c[3]),
        ])
    }
    /// The attributes at barycentric `(u, v)` of a triangle `c0, c1, c2`.
    pub fn barycentric(c: &[CornerAttr; 4], u: f32, v: f32) -> CornerAttr {
        CornerAttr::combine([(1.0 - u - v, c[0]), (u, c[1]), (v, c[2])])
    }
    pub(super) fn close(&self, o: &CornerAttr) -> bool {
        let uv =
            |a: Vec2, b: Vec2| (a - b).abs().max_element() <= 1e-5 * (1.0 + a.abs().max_element());
        uv(self.uv[0], o.uv[0])
            && uv(self.uv[1], o.uv[1])
            && uv(self.lightmap, o.lightmap)
            && (self.color - o.color).abs().max_element() <= 1e-4
    }
}

/// Does object `o` need per-corner attributes (a texture or vertex colours)?
pub(super) fn needs_attributes(o: &Object) -> bool {
    o.material.is_textured() || !o.mesh.colors.is_empty()
}

/// The attributes of vertex `i` of a local-frame shape (see `shape::shaped_objects`).
pub(super) fn vertex_attr(mesh: &Mesh, i: u32) -> CornerAttr {
    let i = i as usize;
    let uv = |k: usize| {
        mesh.uvs
            .get(k)
            .and_then(|s| s.get(i))
            .copied()
            .unwrap_or(Vec2::ZERO)
    };
    CornerAttr {
        uv: [uv(0), uv(1)],
        color: mesh.colors.get(i).copied().unwrap_or(Vec3::ONE),
        lightmap: mesh.lightmap_uvs.get(i).copied().unwrap_or(Vec2::ZERO),
    }
}
