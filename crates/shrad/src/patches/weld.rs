//! Welding patch corners into shading vertices, per object, up to a crease angle.

use glam::Vec3;
use shrad_scene::Mesh;

/// Welds patch corners into shading vertices per object: corners at the same (quantised)
/// position share a vertex when their normals are within the crease angle of the vertex's
/// first normal, so a tessellated sphere shades smooth across its facets while a box's
/// edges stay crisp.
#[derive(Default)]
pub(super) struct Welder {
    /// Quantised position -> the vertices there, with the normal that opened each.
    map: std::collections::HashMap<[i64; 3], Vec<(Vec3, u32)>>,
    pub(super) count: usize,
    /// 1 / the quantum of [`quantum`]: positions that round together are one vertex.
    inv_quantum: f32,
}

/// Cosine of the crease angle (40 degrees): a 24-segment sphere's facets (15 degrees apart)
/// weld, a box's edges (90 degrees) and a 6-sided prism's (60 degrees) do not.
pub(super) const CREASE_COS: f32 = 0.766;

impl Welder {
    pub(super) fn next_object(&mut self, shape: &Mesh) {
        self.map.clear();
        self.inv_quantum = 1.0 / quantum(shape);
    }
    pub(super) fn vertex(&mut self, p: Vec3, n: Vec3) -> u32 {
        let qp = (p * self.inv_quantum).round().as_i64vec3().to_array();
        let here = self.map.entry(qp).or_default();
        if let Some(&(_, id)) = here.iter().find(|(m, _)| m.dot(n) >= CREASE_COS) {
            return id;
        }
        let id = self.count as u32;
        here.push((n, id));
        self.count += 1;
        id
    }
}

/// The length below which two positions of `mesh` are the same point: 1e-5 of its size,
/// so welding and pairing behave alike whatever the scene's unit.
pub(super) fn quantum(mesh: &Mesh) -> f32 {
    let size = mesh.bounds().map_or(1.0, |b| b.size().max_element());
    (1e-5 * size).max(f32::MIN_POSITIVE)
}
