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
use shrad_scene::Aabb;
use shrad_sh::trilinear_weights;

use super::caches::{EmitterCache, ProbeCache};
use super::near_field::NearField;
use super::probe_visibility::ProbeVisibility;
use super::setup::{emitter_groups, self_transfer, EmitterGroup};
use super::DispersiveOptions;
use crate::sparse::SparseRows;
use crate::World;

/// Probe box, per-patch weights and exit directions of one interior object (rest frame:
/// paper 2.3.1 item 3), and its current contribution to the boundary.
pub(super) struct ObjectProbes {
    pub(super) object: usize,
    /// The probe box in the object frame, margin included; the probes sit at its corners.
    pub(super) probe_box: Aabb,
    /// The object's mesh box in its own frame (the probe box before the margin): the near
    /// field's test of what lies under the object (`near_field.rs`).
    pub(super) shape_box: Aabb,
    /// Trilinear weights of each patch (object's patch range order).
    pub(super) weights: Vec<[f32; 8]>,
    /// Exit direction of each patch in the object frame (paper 2.3.4 Step 1).
    pub(super) exit_local: Vec<Vec3>,
    /// Its current contribution to the boundary: (patch, irradiance).
    pub(super) to_boundary: Vec<(u32, Vec3)>,
    /// Where each probe sits, per axis of the box, between the box centre (0) and its corner
    /// (1); repaired probes keep their place until the object moves.
    pub(super) probe_scale: [Vec3; 8],
    /// Step 3 emitters: (centre in the object frame, offsets of its patches in the range,
    /// the receivers it lights).
    pub(super) emitters: Vec<EmitterGroup>,
    /// Per patch transfer vectors with self-visibility in the object frame (empty when off),
    /// `num_coeffs` floats each.
    pub(super) transfer: Vec<f32>,
    /// Per patch, the object's own patches its blocked directions see, with their form
    /// factors (the light the object sends itself, which the transfer vector leaves out):
    /// patch `k`'s row is `self_view.row(k)` (no rows when the transfer is off).
    self_view: SparseRows<(u32, f32)>,
    /// Per patch, the contact openness (see `Dispersive::contact_openness`); empty until
    /// first measured.
    pub(super) openness: Vec<f32>,
    /// `openness` and `near` were measured where the object and its surroundings are now:
    /// false once the object or a neighbour moved (they are geometry only). The last measure
    /// stands in for them in an update that cannot wait for a new one (a coarse update
    /// while it moves, or one over the staleness bound before it is prepared, `prepare.rs`).
    pub(super) openness_current: bool,
    /// The near field (`near_field.rs`), measured with the openness.
    pub(super) near: NearField,
    /// A near field measured in part under a frame's deadline (`near_field_within`): what
    /// is measured, and the offset of the first patch not yet measured.
    pub(super) near_pending: Option<(NearField, usize)>,
    /// The patches (offsets in its range, ascending) whose near field a neighbour's move
    /// may have changed, while the rest of `near` is current (`stale.rs`): only they are
    /// measured again.
    pub(super) near_stale: Vec<u32>,
    /// Where the next slice of a moving object's near field is measured again
    /// (`Dispersive::near_field_follows`), or of its stale patches while a neighbour moves
    /// (`ObjectProbes::take_stale_slice`): an offset in its range.
    pub(super) near_cursor: usize,
    /// Which probes each patch sees (`probe_visibility.rs`; empty when off or unmeasured).
    pub(super) probe_vis: ProbeVisibility,
    /// Step 2's cached probe hits (`caches.rs`).
    pub(super) probe_cache: ProbeCache,
    /// Step 3's cached emitter rays (`caches.rs`).
    pub(super) emitter_cache: EmitterCache,
    /// It moved since the last frame (set by `note_changes`): with `coarse_while_moving`,
    /// an update this frame uses the coarse cameras.
    pub(super) moving: bool,
    /// Its light is from a coarse update: it is updated again, at full resolution, soon
    /// after it stops, and it does not sleep before.
    pub(super) coarse_light: bool,
    /// This frame's update of it is coarse although it rests: under a budget, its full
    /// update is not prepared yet and it may not wait longer (`prepare.rs`).
    pub(super) coarse_now: bool,
    /// The frame its caches were last checked against what movers swept (`stale.rs`).
    pub(super) checked_frame: Option<u64>,
}

impl ObjectProbes {
    /// Precompute object `o` (paper 2.3.1): its box expanded by the margin, the trilinear
    /// weights and exit directions of its patches, its Step 3 emitters and, if enabled, its
    /// transfer vectors. `split`: `emitter_split` where Step 3 gathers, else 1.
    pub(super) fn new(
        world: &World,
        o: usize,
        options: &DispersiveOptions,
        split: u32,
    ) -> ObjectProbes {
        let p = &world.patches;
        let shape = p.shapes[o]
            .bounds()
            .unwrap_or(Aabb::new(Vec3::ZERO, Vec3::ZERO));
        let diagonal = shape.diagonal();
        let margin = options.probe_margin.max(0.0) * diagonal;
        // A flat object still needs a box with volume.
        let pad = Vec3::splat(margin).max(Vec3::splat(1e-4 * diagonal.max(world.eps)));
        let probe_box = shape.padded(pad);
        let (lo, hi) = (probe_box.min, probe_box.max);
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
        let self_view = SparseRows::from_rows(rows);
        ObjectProbes {
            object: o,
            probe_box,
            shape_box: shape,
            weights,
            exit_local,
            to_boundary: Vec::new(),
            probe_scale: [Vec3::ONE; 8],
            emitters: emitter_groups(p, o, centre, options.emitter_per_face, split),
            transfer,
            self_view,
            openness: Vec::new(),
            openness_current: false,
            near: NearField::default(),
            near_pending: None,
            near_stale: Vec::new(),
            near_cursor: 0,
            probe_vis: ProbeVisibility::default(),
            probe_cache: ProbeCache::default(),
            emitter_cache: EmitterCache::default(),
            moving: false,
            coarse_light: false,
            coarse_now: false,
            checked_frame: None,
        }
    }

    /// The stale patches of the near field to measure again now, taken out of
    /// `near_stale`: all of them, or `at_most`, in turn from the first at or past
    /// `near_cursor` (wrapping round), which moves past them; the others stay stale.
    pub(super) fn take_stale_slice(&mut self, at_most: Option<usize>) -> Vec<u32> {
        let stale = std::mem::take(&mut self.near_stale);
        let Some(n) = at_most.filter(|&n| n < stale.len()) else {
            return stale;
        };
        // From the first stale patch at or past the cursor, wrapping round.
        let first = stale.partition_point(|&i| (i as usize) < self.near_cursor);
        let mut slice: Vec<u32> = (0..n).map(|j| stale[(first + j) % stale.len()]).collect();
        self.near_cursor = *slice.last().unwrap_or(&0) as usize + 1;
        self.near_stale = (0..stale.len() - n)
            .map(|j| stale[(first + n + j) % stale.len()])
            .collect();
        self.near_stale.sort_unstable();
        slice.sort_unstable();
        slice
    }

    /// The contact openness and the near field are no longer current, and what was measured
    /// of a new near field is dropped: the object or something within their reach moved
    /// (both are measured again before its next full update).
    pub(super) fn forget_openness(&mut self) {
        self.openness_current = false;
        self.near_pending = None;
        self.near_stale.clear();
    }

    /// Probe `c`'s position in the object frame (its corner, or moved inward if repaired).
    pub(super) fn probe_local(&self, c: usize) -> Vec3 {
        self.probe_at(c, self.probe_scale[c])
    }

    /// Probe `c`'s place at per-axis scale `s` from the box centre (1: the corner).
    pub(super) fn probe_at(&self, c: usize, s: Vec3) -> Vec3 {
        let centre = self.centre_local();
        centre + (self.corner_local(c) - centre) * s
    }

    /// Corner `c` of the box (bit 0: x, bit 1: y, bit 2: z), object frame.
    pub(super) fn corner_local(&self, c: usize) -> Vec3 {
        self.probe_box.corner(c)
    }

    /// Centre of the box, object frame.
    pub(super) fn centre_local(&self) -> Vec3 {
        self.probe_box.centre()
    }

    /// The self form factors of patch `k` (offset in the object's range): (own patch offset,
    /// form factor); empty when the transfer is off.
    pub(super) fn self_view(&self, k: usize) -> &[(u32, f32)] {
        self.self_view.row(k)
    }
}

/// An object's light from its probes, per patch, not yet stored, and what it cost (ms).
pub(super) struct ObjectLight {
    pub(super) e: Vec<Vec3>,
    pub(super) ms: f64,
}

/// Object `k`'s light paths a mover crossed, traced and turned into irradiance ahead of
/// Step 3 (`Dispersive::crossed_ahead`), with the time that took (ms).
pub(super) struct CrossedAhead {
    pub(super) k: usize,
    pub(super) change: Vec<(u32, Vec3)>,
    pub(super) ms: f64,
}

/// A batch's first object as the frame hands it to Step 2's store
/// (`Dispersive::light_selected_objects`).
pub(super) enum FirstObject {
    /// Not lit yet: it is lit there, as the others are (tests that update one object; a
    /// frame always lights its first object beside Step 1).
    #[cfg(test)]
    NotLit,
    /// Lit beside Step 1 (`Dispersive::light_first_object`): its light, or `None` when its
    /// update was not ready (it waits, as a late object does).
    Lit(Option<ObjectLight>),
}
