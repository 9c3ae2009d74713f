//! The dispersive solver's set-up, shared by the steps (paper 2.3.1, "初始化"): which
//! patches are lit as the boundary, each object's world box, the outer sides of the
//! enclosure, the boundary's neighbourhoods (Step 3's splat smoothing), each object's
//! transfer vectors (Step 2) and emitter groups (Step 3). Computed once, when the solver is
//! made (and, for boxes, when objects move); the step files read them and import nothing from
//! one another.

use glam::Vec3;
use shrad_scene::{Aabb, Role};
use shrad_sh::{eval_basis, num_coeffs};
use shrad_vis::Hit;

use crate::sparse::SparseRows;
use crate::World;

/// Whether patch `i` is lit like the boundary (Steps 1, 3, 4 and the wall exchange): the
/// boundary's patches, and those of lights that also reflect (a lamp panel, an emissive
/// card: the paper's lights only emit, but a reflective emitter near a wall otherwise
/// loses the light it bounces back).
pub(super) fn receives_as_boundary(world: &World, i: usize) -> bool {
    match world.patches.role(i) {
        Role::Boundary => true,
        Role::Light => world.reflectance[i].max_element() > 0.0,
        Role::Interior => false,
    }
}

/// World bounding box of object `o` (its rest-frame mesh box, transformed).
pub(super) fn world_box(world: &World, o: usize) -> Aabb {
    world.patches.world_box(o)
}

/// See `Dispersive::outer_side`.
pub(super) fn outer_sides(world: &World) -> Vec<bool> {
    let p = &world.patches;
    let centre = world.scene.bounds().map_or(Vec3::ZERO, |b| b.centre());
    let boxes: Vec<Vec3> = (0..p.object_role.len())
        .map(|o| world_box(world, o).centre())
        .collect();
    (0..p.len())
        .map(|i| {
            let twin = p.twin[i] != crate::patches::NO_PATCH;
            match p.role(i) {
                Role::Boundary => twin && p.normal[i].dot(centre - p.centre[i]) < 0.0,
                // The inside of a double-sided interior object (Blender's default): a probe
                // that sees it is buried in the object, as one seeing a back face is (the
                // animated room's rider has 3 probes inside the box it rides on, seeing
                // its dark inside: its sides were 45 % too dark).
                Role::Interior => {
                    let o = p.object[i] as usize;
                    twin && p.normal[i].dot(boxes[o] - p.centre[i]) > 0.0
                }
                Role::Light => false,
            }
        })
        .collect()
}

/// Rays per light patch for the energy meter's measure of what the lights absorb.
pub(super) const LIGHT_METER_RAYS: usize = 16;

/// Boundary patches around each boundary patch: those sharing one of its smooth-shading
/// vertices (corners welded by position within the crease angle), itself first. Compressed
/// rows over all patches; non-boundary patches have none.
#[derive(Default)]
pub(super) struct Neighbours {
    /// Row `i`: patch `i` itself, then its neighbours (empty for a patch not on the
    /// boundary).
    rows: SparseRows<u32>,
    /// 1 / the summed area of each patch's neighbourhood.
    pub(super) inv_area: Vec<f32>,
}

impl Neighbours {
    pub(super) fn of_boundary(world: &World) -> Neighbours {
        let p = &world.patches;
        let boundary = |i: usize| receives_as_boundary(world, i);
        // Patches at each shading vertex, as compressed rows (no allocation per vertex:
        // a 1M-patch scene has about as many vertices).
        let corners = |i: usize| {
            let mut v = p.corner_vertex[i];
            v.sort_unstable();
            (0..4)
                .filter(move |&k| k == 0 || v[k - 1] != v[k])
                .map(move |k| v[k])
        };
        let mut vertex_start = vec![0u32; p.shading_vertex_count + 1];
        for i in (0..p.len()).filter(|&i| boundary(i)) {
            for c in corners(i) {
                vertex_start[c as usize + 1] += 1;
            }
        }
        for v in 0..p.shading_vertex_count {
            vertex_start[v + 1] += vertex_start[v];
        }
        let mut fill = vertex_start.clone();
        let mut vertex_patches = vec![0u32; *vertex_start.last().unwrap_or(&0) as usize];
        for i in (0..p.len()).filter(|&i| boundary(i)) {
            for c in corners(i) {
                vertex_patches[fill[c as usize] as usize] = i as u32;
                fill[c as usize] += 1;
            }
        }
        let at_vertex = |c: u32| {
            &vertex_patches
                [vertex_start[c as usize] as usize..vertex_start[c as usize + 1] as usize]
        };
        let mut rows = SparseRows::default();
        let mut near = Vec::new();
        for i in 0..p.len() {
            near.clear();
            if boundary(i) {
                for &c in &p.corner_vertex[i] {
                    near.extend(at_vertex(c).iter().filter(|&&k| k as usize != i));
                }
                near.sort_unstable();
                near.dedup();
                near.insert(0, i as u32);
            }
            rows.push_row(near.iter().copied());
        }
        let mut n = Neighbours {
            rows,
            inv_area: Vec::new(),
        };
        n.inv_area = (0..p.len())
            .map(|i| {
                let a: f32 = n.of(i).iter().map(|&k| p.area[k as usize]).sum();
                if a > 0.0 {
                    1.0 / a
                } else {
                    0.0
                }
            })
            .collect();
        n
    }

    pub(super) fn of(&self, i: usize) -> &[u32] {
        self.rows.row(i)
    }
}

/// Transfer vectors with self-visibility of object `o`'s patches, in the object frame:
/// `T_i = (pi / M) sum_j V_self(w_j) Y(w_j)` over `M` cosine-distributed directions (the
/// pdf `cos / pi` turns the cosine-weighted integral into this mean). Rays are cast in the
/// world at rest with every other object transparent, so only the object itself occludes.
pub(super) fn self_transfer(
    world: &World,
    o: usize,
    bands: usize,
    rays: u32,
) -> (Vec<f32>, Vec<Vec<(u32, f32)>>) {
    if rays == 0 {
        return (Vec::new(), Vec::new());
    }
    let p = &world.patches;
    let nc = num_coeffs(bands);
    let rays = rays as usize;
    let others: Vec<u32> = (0..p.object_role.len() as u32)
        .filter(|&x| x as usize != o)
        .collect();
    let m = p.world_from_local[o];
    let range = p.range(o);
    let mut origins = vec![Vec3::ZERO; range.len() * rays];
    let mut dirs_world = vec![Vec3::ZERO; range.len() * rays];
    let mut dirs_local = vec![Vec3::ZERO; range.len() * rays];
    for (k, i) in range.clone().enumerate() {
        for j in 0..rays {
            let local = transfer_direction(p, i, j, rays);
            dirs_local[k * rays + j] = local;
            dirs_world[k * rays + j] = m.transform_vector3(local).normalize_or_zero();
            origins[k * rays + j] = p.centre[i] + p.normal[i] * world.eps;
        }
    }
    let mut hits = vec![Hit::MISS; origins.len()];
    world
        .vis
        .closest(&origins, &dirs_world, 0.0, &others, &mut hits);
    let mut transfer = vec![0f32; range.len() * nc];
    let mut basis = [0f32; 64];
    let w = std::f32::consts::PI / rays as f32;
    let mut self_view = vec![Vec::new(); range.len()];
    for (k, t) in transfer.chunks_mut(nc).enumerate() {
        for j in 0..rays {
            let h = &hits[k * rays + j];
            if h.is_hit() {
                if let Some(q) = world.seen_patch(h) {
                    let row: &mut Vec<(u32, f32)> = &mut self_view[k];
                    let q = (q - range.start) as u32;
                    match row.iter_mut().find(|e| e.0 == q) {
                        Some(e) => e.1 += 1.0 / rays as f32,
                        None => row.push((q, 1.0 / rays as f32)),
                    }
                }
                continue;
            }
            eval_basis(bands, dirs_local[k * rays + j], &mut basis[..nc]);
            for c in 0..nc {
                t[c] += w * basis[c];
            }
        }
    }
    (transfer, self_view)
}

/// Ray `j` of `rays` from patch `i` (rest frame, cosine-distributed about its normal): the
/// transfer vectors' directions, and the near field's (`near_field.rs`), so that with as
/// many rays both see the same directions.
pub(super) fn transfer_direction(p: &crate::Patches, i: usize, j: usize, rays: usize) -> Vec3 {
    let shift = (
        crate::sampling::unit(crate::sampling::hash(i as u32 ^ 0x5eed)),
        0.25,
    );
    let (u, v) = crate::sampling::hammersley(j as u32, rays as u32, shift);
    crate::sampling::square_to_cosine_hemisphere(u, v, p.normal_local[i])
}

/// Which boundary patches a Step 3 emitter gathers to, by where they are in the object's
/// frame: all, or those within or beyond `radius` of `around` (a face's split emitters
/// light its near receivers, the whole face's emitter the others).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Reach {
    All,
    Within { around: Vec3, radius: f32 },
    Beyond { around: Vec3, radius: f32 },
}

impl Reach {
    /// Whether a receiver at `local` (the object's frame) is this emitter's.
    pub(super) fn takes(&self, local: Vec3) -> bool {
        match *self {
            Reach::All => true,
            Reach::Within { around, radius } => local.distance_squared(around) < radius * radius,
            Reach::Beyond { around, radius } => local.distance_squared(around) >= radius * radius,
        }
    }
}

/// One Step 3 emitter: its centre (object frame), its patches (offsets in the object's
/// range) and the receivers it lights.
pub(super) type EmitterGroup = (Vec3, Vec<u32>, Reach);

/// The Step 3 emitters of object `o`: one at the box centre with every patch (the paper), or
/// one per dominant normal axis (±x, ±y, ±z of the rest frame) at the area-weighted
/// centroid of its patches; with `split > 1`, each of those also split into `split x split`
/// emitters across its face that light the receivers near the face ([`split_group`]).
pub(super) fn emitter_groups(
    p: &crate::Patches,
    o: usize,
    box_centre: Vec3,
    per_face: bool,
    split: u32,
) -> Vec<EmitterGroup> {
    let range = p.range(o);
    if !per_face {
        return vec![(box_centre, (0..range.len() as u32).collect(), Reach::All)];
    }
    let mut groups: Vec<(Vec3, f32, Vec<u32>)> = vec![(Vec3::ZERO, 0.0, Vec::new()); 6];
    for (k, i) in range.clone().enumerate() {
        let n = p.normal_local[i];
        let axis = n.abs().max_position();
        let g = 2 * axis + usize::from(n[axis] < 0.0);
        groups[g].0 += p.centre_local[i] * p.area[i];
        groups[g].1 += p.area[i];
        groups[g].2.push(k as u32);
    }
    groups
        .into_iter()
        .enumerate()
        .filter(|g| g.1 .1 > 0.0)
        .flat_map(|(g, (sum, area, members))| {
            split_group(p, range.start, g / 2, (sum / area, members), split as usize)
        })
        .collect()
}

/// One face direction's emitter (normal axis `axis`; centre and members, offsets from
/// `start`), and with `n > 1` its face split into `n x n` cells of equal extent (its two
/// other axes), each an emitter at its own area-weighted centroid.
///
/// The split cells light the receivers within twice the face's in-plane diagonal of its
/// centre, the whole face the rest (once the diagonal: Cornell 3.52 % against 3.37; the
/// cost the same within the bench's noise): one emitter stands for the face at one point, and for a face as
/// large as its distance to the floor at its foot (the Cornell blocks) that point, at the
/// face's middle, sees the floor at a grazing angle from twice the height. The floor
/// between the two blocks was 30 % too dark and the back wall behind the tall block 40-50 %
/// too bright (docs/results.md §14). Far away the point is right, and the cells' receivers
/// are few, so the split costs little.
fn split_group(
    p: &crate::Patches,
    start: usize,
    axis: usize,
    (centre, members): (Vec3, Vec<u32>),
    n: usize,
) -> Vec<EmitterGroup> {
    if n <= 1 || members.len() < 2 * n * n {
        return vec![(centre, members, Reach::All)];
    }
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let at = |m: u32| p.centre_local[start + m as usize];
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for &m in &members {
        lo = lo.min(at(m));
        hi = hi.max(at(m));
    }
    let cell = |x: f32, a: usize| {
        let span = (hi[a] - lo[a]).max(1e-12);
        (((x - lo[a]) / span * n as f32) as usize).min(n - 1)
    };
    let mut cells: Vec<(Vec3, f32, Vec<u32>)> = vec![(Vec3::ZERO, 0.0, Vec::new()); n * n];
    for &m in &members {
        let x = at(m);
        let k = cell(x[b], b) * n + cell(x[c], c);
        let a = p.area[start + m as usize];
        cells[k].0 += x * a;
        cells[k].1 += a;
        cells[k].2.push(m);
    }
    let radius = 2.0 * Vec3::new(hi[b] - lo[b], hi[c] - lo[c], 0.0).length();
    let within = Reach::Within {
        around: centre,
        radius,
    };
    let mut out = vec![(
        centre,
        members,
        Reach::Beyond {
            around: centre,
            radius,
        },
    )];
    out.extend(
        cells
            .into_iter()
            .filter(|g| g.1 > 0.0)
            .map(|(sum, area, members)| (sum / area, members, within)),
    );
    out
}
