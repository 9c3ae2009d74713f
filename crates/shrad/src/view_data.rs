//! What a viewer draws, read from an [`Engine`] without changing it (`shrad view`):
//!
//! - the display mesh: each object's shading vertices (the patch corners welded by position
//!   and normal, as `render` interpolates them) in its local frame, and its triangles;
//! - per-vertex radiosity of one channel: total, direct only (`M + rho E_direct`) or indirect
//!   only (the rest);
//! - the dispersive solver's probes ([`crate::dispersive::inspect`]).

use std::borrow::Cow;

use glam::Vec3;
use shrad_scene::Role;

use crate::dispersive::inspect::ProbeView;
use crate::engine::Engine;
use crate::solver::Solver;
use crate::World;

/// One object of the display mesh.
#[derive(Clone, Debug)]
pub struct DisplayObject {
    /// Its name in the scene.
    pub name: String,
    /// Boundary, interior or light.
    pub role: Role,
    /// Its vertices in the local frame (draw them under `Patches::world_from_local`).
    pub positions: Vec<Vec3>,
    /// Triangles, counter-clockwise from the front, indexing `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Where its vertices start in [`DisplayMesh`]'s vertex order (the order of
    /// [`DisplayMesh::gather`]'s output).
    pub first_vertex: u32,
}

/// Every object's drawable mesh, and the shading vertex behind each display vertex.
#[derive(Clone, Debug, Default)]
pub struct DisplayMesh {
    /// Objects in scene order.
    pub objects: Vec<DisplayObject>,
    /// Display vertex -> shading vertex (`Patches::corner_vertex` numbering).
    vertex_ids: Vec<u32>,
    /// Display vertex -> the first patch (in patch order) with a corner there.
    vertex_patches: Vec<u32>,
}

impl DisplayMesh {
    /// The mesh of `world`'s patches: quads as two triangles, triangles as one.
    pub fn new(world: &World) -> DisplayMesh {
        let p = &world.patches;
        let mut local_of = vec![u32::MAX; p.shading_vertex_count];
        let mut vertex_ids = Vec::with_capacity(p.shading_vertex_count);
        let mut vertex_patches = Vec::with_capacity(p.shading_vertex_count);
        let mut objects = Vec::with_capacity(p.object_ranges.len());
        for (o, object) in world.scene.objects.iter().enumerate() {
            let first_vertex = vertex_ids.len() as u32;
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for i in p.range(o) {
                let corners = if p.is_quad[i] { 4 } else { 3 };
                let mut local = [0u32; 4];
                for k in 0..corners {
                    let v = p.corner_vertex[i][k] as usize;
                    if local_of[v] == u32::MAX {
                        local_of[v] = positions.len() as u32;
                        positions.push(p.corners[i][k]);
                        vertex_ids.push(v as u32);
                        vertex_patches.push(i as u32);
                    }
                    local[k] = local_of[v];
                }
                triangles.push([local[0], local[1], local[2]]);
                if corners == 4 {
                    triangles.push([local[0], local[2], local[3]]);
                }
            }
            objects.push(DisplayObject {
                name: object.name.clone(),
                role: p.object_role[o],
                positions,
                triangles,
                first_vertex,
            });
        }
        DisplayMesh {
            objects,
            vertex_ids,
            vertex_patches,
        }
    }

    /// Number of display vertices.
    pub fn vertex_count(&self) -> usize {
        self.vertex_ids.len()
    }

    /// A per-shading-vertex value in display-vertex order.
    pub fn gather(&self, per_shading_vertex: &[Vec3]) -> Vec<Vec3> {
        self.vertex_ids
            .iter()
            .map(|&v| {
                per_shading_vertex
                    .get(v as usize)
                    .copied()
                    .unwrap_or(Vec3::ZERO)
            })
            .collect()
    }

    /// A per-patch value in display-vertex order: at each vertex, that of the first patch
    /// with a corner there (`Patches::normal` gives each vertex the normal of a patch of
    /// its own, as the shading vertices are welded within the crease angle).
    pub fn gather_patches(&self, per_patch: &[Vec3]) -> Vec<Vec3> {
        self.vertex_patches
            .iter()
            .map(|&i| per_patch.get(i as usize).copied().unwrap_or(Vec3::ZERO))
            .collect()
    }
}

/// Which part of the light a viewer shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// The radiosity `B`.
    Total,
    /// Emission plus reflected direct light, `M + rho E_direct`.
    Direct,
    /// `B` less the direct channel (clamped at 0): light that bounced at least twice.
    Indirect,
}

/// The direct irradiance of every patch: the dispersive solver's own (Step 1) when it holds
/// it for every patch, else computed here with `samples` shadow rays per (patch, light),
/// which costs as much as the reference's direct pass.
pub fn direct_irradiance(engine: &Engine, samples: u32) -> Cow<'_, [Vec3]> {
    if let Solver::Dispersive(d) = &engine.solver {
        if let Some(direct) = d.direct_irradiance() {
            return Cow::Borrowed(direct);
        }
    }
    let world = engine.world();
    let all: Vec<u32> = (0..world.patches.len() as u32).collect();
    Cow::Owned(crate::direct::direct_irradiance(world, &all, samples))
}

/// Per-patch radiosity of `channel`; `direct` is [`direct_irradiance`] (unused for
/// [`Channel::Total`]).
pub fn channel_radiosity(engine: &Engine, channel: Channel, direct: &[Vec3]) -> Vec<Vec3> {
    let world = engine.world();
    let b = engine.radiosity();
    let direct_part = |i: usize| {
        world.exitance[i] + world.reflectance[i] * direct.get(i).copied().unwrap_or(Vec3::ZERO)
    };
    match channel {
        Channel::Total => b.to_vec(),
        Channel::Direct => (0..b.len()).map(direct_part).collect(),
        Channel::Indirect => (0..b.len())
            .map(|i| (b[i] - direct_part(i)).max(Vec3::ZERO))
            .collect(),
    }
}

/// The dispersive solver's probes as they stand now (see
/// [`Dispersive::probe_views`](crate::dispersive::Dispersive::probe_views)); `None` for the
/// other solvers, whose probes are not per object.
pub fn probes(engine: &Engine) -> Option<Vec<ProbeView>> {
    match &engine.solver {
        Solver::Dispersive(d) => Some(d.probe_views(engine.world())),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::SolverChoice;
    use crate::PatchSizing;

    #[test]
    fn display_mesh_covers_every_patch_and_channels_add_up() {
        let mut e = Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(600),
            shrad_vis::Backend::Auto,
            SolverChoice::Dispersive(Default::default()),
        )
        .unwrap();
        e.converge(2);
        let mesh = DisplayMesh::new(e.world());
        let p = &e.world().patches;
        let triangles: usize = mesh.objects.iter().map(|o| o.triangles.len()).sum();
        let expected: usize = (0..p.len()).map(|i| if p.is_quad[i] { 2 } else { 1 }).sum();
        assert_eq!(triangles, expected);
        assert_eq!(mesh.vertex_count(), p.shading_vertex_count);
        let direct = direct_irradiance(&e, 16);
        let total = channel_radiosity(&e, Channel::Total, &direct);
        let d = channel_radiosity(&e, Channel::Direct, &direct);
        let ind = channel_radiosity(&e, Channel::Indirect, &direct);
        for i in 0..total.len() {
            assert!(
                (d[i] + ind[i] - total[i]).abs().max_element()
                    <= 1e-3 * (1.0 + total[i].max_element())
            );
        }
        // Light bounces in a closed box: the indirect channel is not empty.
        assert!(ind.iter().map(|v| v.max_element()).sum::<f32>() > 0.0);
        let probes = probes(&e).unwrap();
        let interior = p
            .object_role
            .iter()
            .filter(|r| **r == Role::Interior)
            .count();
        assert_eq!(probes.len(), 8 * interior);
        assert!(probes.iter().all(|q| q.position.is_finite()));
    }
}
