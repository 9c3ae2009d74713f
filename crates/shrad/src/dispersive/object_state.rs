//! Per interior object, what the paper precomputes in its initialisation (2.3.1 items 2–3)
//! and what Steps 2 and 3 keep between frames: the probe box (its 8 corners are the probes of
//! 2.3.3 Step 2), each patch's trilinear weights (2.3.3 Step 4) and exit direction (2.3.4
//! Step 1), all in the rest frame, so they are invariant under rigid motion.
//!
//! The per-patch data are flat arrays in the object's patch-range order (structure of
//! arrays): `weights[k]`, `exit_local[k]`, `transfer[k * nc..(k + 1) * nc]`, and the self
//! form factors as compressed rows (`self_view(k)`), so Step 2's loop over an object's
//! patches reads contiguous memory. What the scheduler reads (staleness, disturbance, cost)
//! lives in the scheduler.

use glam::Vec3;
use shrad_sh::trilinear_weights;

use super::step2_probes::self_transfer;
use super::step3_to_boundary::emitter_groups;
use super::DispersiveOptions;
use crate::World;

/// Probe box, per-patch weights and exit directions of one interior object (rest frame:
/// paper 2.3.1 item 3), and its current contribution to the boundary.
pub(super) struct ObjectProbes {
    pub(super) object: usize,
    /// Box `(lo, hi)` in the object frame, margin included.
    pub(super) lo: Vec3,
    pub(super) hi: Vec3,
    /// Trilinear weights of each patch (object's patch range order).
    pub(super) weights: Vec<[f32; 8]>,
    /// Exit direction of each patch in the object frame (paper 2.3.4 Step 1).
    pub(super) exit_local: Vec<Vec3>,
    /// Its current contribution to the boundary: (patch, irradiance).
    pub(super) to_boundary: Vec<(u32, Vec3)>,
    /// Where each probe sits on the line from the box centre to its corner (1: the corner);
    /// repaired probes keep their place until the object moves.
    pub(super) probe_scale: [f32; 8],
    /// Step 3 emitters: (centre in the object frame, offsets of its patches in the range).
    pub(super) emitters: Vec<(Vec3, Vec<u32>)>,
    /// Per patch transfer vectors with self-visibility in the object frame (empty when off),
    /// `num_coeffs` floats each.
    pub(super) transfer: Vec<f32>,
    /// Per patch, the object's own patches its blocked directions see, with their form
    /// factors (the light the object sends itself, which the transfer vector leaves out):
    /// compressed rows, patch `k`'s in `self_view[self_view_start[k]..self_view_start[k + 1]]`
    /// (`self_view_start` is empty when the transfer is off).
    self_view_start: Vec<u32>,
    self_view: Vec<(u32, f32)>,
    /// Per patch, the contact openness (see `Dispersive::contact_openness`); empty until
    /// computed and again when the object or a neighbour moves (it is geometry only).
    pub(super) openness: Vec<f32>,
}

impl ObjectProbes {
    /// Precompute object `o` (paper 2.3.1): its box expanded by the margin, the trilinear
    /// weights and exit directions of its patches, its Step 3 emitters and, if enabled, its
    /// transfer vectors.
    pub(super) fn new(world: &World, o: usize, options: &DispersiveOptions) -> ObjectProbes {
        let p = &world.patches;
        let (mut lo, mut hi) = p.shapes[o].bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let margin = options.probe_margin.max(0.0) * (hi - lo).length();
        // A flat object still needs a box with volume.
        let pad = Vec3::splat(margin).max(Vec3::splat(1e-4 * (hi - lo).length().max(world.eps)));
        lo -= pad;
        hi += pad;
        let range = p.range(o);
        let centre = 0.5 * (lo + hi);
        let weights = range
            .clone()
            .map(|i| {
                trilinear_weights(
                    ((p.centre_local[i] - lo) / (hi - lo)).clamp(Vec3::ZERO, Vec3::ONE),
                )
            })
            .collect();
        // paper 2.3.4, Step 1: halfway between "from the centre" and "along the normal".
        let exit_local = range
            .map(|i| {
                ((p.centre_local[i] - centre).normalize_or_zero() + p.normal_local[i])
                    .normalize_or(p.normal_local[i])
            })
            .collect();
        let (transfer, rows) = self_transfer(world, o, options.bands, options.self_shadow_rays);
        let mut self_view_start = Vec::with_capacity(rows.len() + 1);
        if !rows.is_empty() {
            self_view_start.push(0);
        }
        let mut self_view = Vec::new();
        for row in rows {
            self_view.extend(row);
            self_view_start.push(self_view.len() as u32);
        }
        ObjectProbes {
            object: o,
            lo,
            hi,
            weights,
            exit_local,
            to_boundary: Vec::new(),
            probe_scale: [1.0; 8],
            emitters: emitter_groups(p, o, centre, options.emitter_per_face),
            transfer,
            self_view_start,
            self_view,
            openness: Vec::new(),
        }
    }

    /// Probe `c`'s position in the object frame (its corner, or moved inward if repaired).
    pub(super) fn probe_local(&self, c: usize) -> Vec3 {
        let centre = self.centre_local();
        centre + (self.corner_local(c) - centre) * self.probe_scale[c]
    }

    /// Corner `c` of the box (bit 0: x, bit 1: y, bit 2: z), object frame.
    pub(super) fn corner_local(&self, c: usize) -> Vec3 {
        let s = Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
        self.lo + (self.hi - self.lo) * s
    }

    /// Centre of the box, object frame.
    pub(super) fn centre_local(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// The self form factors of patch `k` (offset in the object's range): (own patch offset,
    /// form factor); empty when the transfer is off.
    pub(super) fn self_view(&self, k: usize) -> &[(u32, f32)] {
        match (self.self_view_start.get(k), self.self_view_start.get(k + 1)) {
            (Some(&a), Some(&b)) => &self.self_view[a as usize..b as usize],
            _ => &[],
        }
    }
}
