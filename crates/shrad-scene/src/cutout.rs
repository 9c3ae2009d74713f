//! Alpha cut-outs resolved in geometry at load, for both readers: a glTF `alphaMode: MASK`
//! base colour texture (`gltf_io/cutout.rs`) and an OBJ material's `map_d` (`obj_io/maps.rs`).
//!
//! shrad's patches are opaque, and nothing tests a ray against a texture's alpha. So the
//! cut-outs of an alpha texture (a leaf card, a fence) become geometry: each triangle of a
//! mesh is replaced by the parts of it whose alpha (the texture's, with its sampler, times a
//! uniform factor, times a per-vertex alpha if there is one) is at least a cutoff (glTF's
//! `alphaCutoff`, glTF 2.0 "Alpha Coverage", default 0.5; 0.5 for OBJ).
//!
//! A triangle is cut in its texture's UV space by midpoint subdivision (each triangle into
//! four), down to sub-triangles about one texel across (at most [`MAX_DEPTH`] levels: 4096
//! pieces). A (sub-)triangle all of whose covered texels are at or above the cutoff (the
//! alpha any sample in it can take is bounded by its texels' least and greatest, see
//! [`Texture::alpha_bounds`]) is kept whole, one all below is dropped, and only a mixed one is
//! divided further; at the last level a piece is kept when the alpha at its centroid is.
//! Nothing is merged: a triangle's pieces share the vertices of its subdivision lattice,
//! whose positions, texture coordinates, colours and lightmap coordinates are the linear
//! interpolation of its corners'. The pieces a file's cut-outs add are capped
//! ([`MAX_ADDED`]); beyond that, triangles stay whole (opaque) with a warning.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::{Mesh, Texture};

/// Deepest subdivision of a triangle (4^6 = 4096 pieces).
pub(crate) const MAX_DEPTH: u32 = 6;

/// Most triangles the cut-outs of one file may add.
pub(crate) const MAX_ADDED: usize = 2_000_000;

/// Most texels scanned for the alpha bounds of one (sub-)triangle: a larger one is divided
/// without being scanned.
const MAX_SCAN: u64 = 1 << 16;

/// A point of a triangle's subdivision lattice: `(i, j)` of `n`, barycentric weights
/// `((n - i - j) / n, i / n, j / n)` on its corners.
type Lattice = [u32; 2];

/// What one mesh's cut-out test reads.
pub(crate) struct Mask<'t> {
    /// The alpha texture (its sampler, transform and coordinate set): its image's alpha
    /// plane is what is read.
    pub texture: &'t Texture,
    /// The cutoff: alpha at or above it is kept.
    pub cutoff: f32,
    /// A uniform factor on the alpha (glTF's base colour factor's alpha).
    pub factor: f32,
    /// Alpha per vertex (glTF's `COLOR_0`), if the mesh has one that is not all 1.
    pub color_alpha: Option<Vec<f32>>,
}

/// One triangle being cut: its corners' texel coordinates, texture coordinates and alphas.
struct Tri<'m> {
    mask: &'m Mask<'m>,
    n: u32,
    depth: u32,
    texel: [Vec2; 3],
    uv: [Vec2; 3],
    color: [f32; 3],
}

impl Tri<'_> {
    fn weights(&self, p: Lattice) -> Vec3 {
        let n = self.n as f32;
        let (i, j) = (p[0] as f32, p[1] as f32);
        Vec3::new((n - i - j) / n, i / n, j / n)
    }

    fn lerp2(v: &[Vec2; 3], w: Vec3) -> Vec2 {
        v[0] * w.x + v[1] * w.y + v[2] * w.z
    }

    fn lerp1(v: &[f32; 3], w: Vec3) -> f32 {
        v[0] * w.x + v[1] * w.y + v[2] * w.z
    }

    /// The pieces of sub-triangle `t` (at subdivision `level`) that are kept, into `out`.
    fn visit(&self, t: [Lattice; 3], level: u32, out: &mut Vec<[Lattice; 3]>) {
        let w = t.map(|p| self.weights(p));
        let texel = w.map(|w| Self::lerp2(&self.texel, w));
        let color = w.map(|w| Self::lerp1(&self.color, w));
        let lo = texel[0].min(texel[1]).min(texel[2]);
        let hi = texel[0].max(texel[1]).max(texel[2]);
        let (cmin, cmax) = (
            color[0].min(color[1]).min(color[2]),
            color[0].max(color[1]).max(color[2]),
        );
        let (f, cutoff) = (self.mask.factor, self.mask.cutoff);
        if let Some((a, b)) = self.mask.texture.alpha_bounds(lo, hi, MAX_SCAN) {
            if a * f * cmin >= cutoff {
                out.push(t);
                return;
            }
            if b * f * cmax < cutoff {
                return;
            }
        }
        if level >= self.depth {
            let c = (w[0] + w[1] + w[2]) / 3.0;
            let uv = Self::lerp2(&self.uv, c);
            let alpha = self.mask.texture.sample_alpha(uv) * f * Self::lerp1(&self.color, c);
            if alpha >= cutoff {
                out.push(t);
            }
            return;
        }
        let mid = |a: Lattice, b: Lattice| [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2];
        let [a, b, c] = t;
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        for s in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
            self.visit(s, level + 1, out);
        }
    }
}

/// How many levels triangle corners `texel` (in texel space) are divided to at most: until
/// a piece's longest edge is about a texel, at most [`MAX_DEPTH`].
fn depth_for(texel: &[Vec2; 3]) -> u32 {
    let e = (texel[0] - texel[1])
        .length()
        .max((texel[1] - texel[2]).length())
        .max((texel[2] - texel[0]).length());
    if !e.is_finite() {
        return MAX_DEPTH;
    }
    if e <= 1.0 {
        return 0;
    }
    (e.log2().ceil() as u32).min(MAX_DEPTH)
}

/// The result of cutting one mesh.
pub(crate) struct Cut {
    /// Triangles before.
    pub from: usize,
    /// Triangles after.
    pub to: usize,
    /// Whether [`MAX_ADDED`] stopped a triangle from being cut (it stayed whole).
    pub capped: bool,
}

/// Cut `mesh` by `mask` (see the module's documentation), adding at most `*budget`
/// triangles (which it spends). None when nothing can be cut away (every alpha it may
/// have is at or above the cutoff): the mesh is left as it is.
pub(crate) fn cut(mesh: &mut Mesh, mask: &Mask, budget: &mut usize) -> Option<Cut> {
    let uvs = mesh.uvs.get(mask.texture.tex_coord as usize)?.clone();
    let (lo, _) = mask.texture.image.alpha_range();
    let cmin = mask
        .color_alpha
        .as_ref()
        .map_or(1.0, |c| c.iter().copied().fold(1.0, f32::min));
    if lo * mask.factor * cmin >= mask.cutoff {
        return None;
    }
    let from = mesh.triangles.len();
    let mut capped = false;
    let mut triangles = Vec::with_capacity(from);
    let mut pieces = Vec::new();
    for t in std::mem::take(&mut mesh.triangles) {
        let uv = t.map(|i| uvs[i as usize]);
        let texel = uv.map(|p| mask.texture.texel_coords(p));
        let depth = depth_for(&texel);
        let tri = Tri {
            mask,
            n: 1 << depth,
            depth,
            texel,
            uv,
            color: t.map(|i| mask.color_alpha.as_ref().map_or(1.0, |c| c[i as usize])),
        };
        let n = tri.n;
        pieces.clear();
        tri.visit([[0, 0], [n, 0], [0, n]], 0, &mut pieces);
        if pieces.len() == 1 && pieces[0] == [[0, 0], [n, 0], [0, n]] {
            triangles.push(t);
            continue;
        }
        if pieces.len() > *budget {
            capped = true;
            triangles.push(t);
            continue;
        }
        *budget -= pieces.len();
        add_pieces(mesh, t, &tri, &pieces, &mut triangles);
    }
    mesh.triangles = triangles;
    Some(Cut {
        from,
        to: mesh.triangles.len(),
        capped,
    })
}

/// Append the `pieces` of triangle `t` to `out`, with the lattice vertices they need (the
/// corners are `t`'s own).
fn add_pieces(
    mesh: &mut Mesh,
    t: [u32; 3],
    tri: &Tri,
    pieces: &[[Lattice; 3]],
    out: &mut Vec<[u32; 3]>,
) {
    let n = tri.n;
    let mut index: HashMap<Lattice, u32> =
        HashMap::from([([0, 0], t[0]), ([n, 0], t[1]), ([0, n], t[2])]);
    for piece in pieces {
        out.push(piece.map(|p| {
            *index.entry(p).or_insert_with(|| {
                let w = tri.weights(p);
                add_vertex(mesh, t, w)
            })
        }));
    }
}

/// A new vertex of `mesh` at barycentric weights `w` of triangle `t`: every per-vertex
/// attribute interpolated linearly. Returns its index.
fn add_vertex(mesh: &mut Mesh, t: [u32; 3], w: Vec3) -> u32 {
    let [a, b, c] = t.map(|i| i as usize);
    let p = &mesh.positions;
    let q = p[a] * w.x + p[b] * w.y + p[c] * w.z;
    mesh.positions.push(q);
    let lerp2 = |v: &Vec<Vec2>| v[a] * w.x + v[b] * w.y + v[c] * w.z;
    for set in &mut mesh.uvs {
        let q = lerp2(set);
        set.push(q);
    }
    if !mesh.lightmap_uvs.is_empty() {
        let q = lerp2(&mesh.lightmap_uvs);
        mesh.lightmap_uvs.push(q);
    }
    if !mesh.colors.is_empty() {
        let k = &mesh.colors;
        let q = k[a] * w.x + k[b] * w.y + k[c] * w.z;
        mesh.colors.push(q);
    }
    (mesh.positions.len() - 1) as u32
}
