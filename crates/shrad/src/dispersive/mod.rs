//! The dispersive method of Wang, Liu and Wu (2007), spec section 4.
//!
//! Every interior object carries 8 SH light probes at the corners of its rest-frame bounding
//! box (expanded by a margin). A frame updates only the objects the scheduler picks:
//!
//! 1. direct light on the boundary (paper 2.3.2) — cached until a light or an occluder moves;
//! 2. light the selected objects from their probes (paper 2.3.3): capture, project to SH,
//!    interpolate trilinearly to each patch, dot with the patch's clamped-cosine lobe;
//! 3. each selected object lights the boundary as one SH emitter at its centre (paper 2.3.4),
//!    replacing its previous contribution;
//! 4. assemble the boundary's radiosity (paper 2.3.5).
//!
//! Beyond the paper (spec 4.6), each switchable and measured against the reference in
//! `docs/results.md`: probe validity and repair, wall-to-wall exchange among the static
//! boundary patches, seeing through the object's own geometry when capturing, direct light on
//! interior patches computed explicitly (probes then carry reflected light only), and a
//! priority scheduler with a staleness bound and a time budget. `DispersiveOptions::paper()`
//! is the paper as written.

use std::time::Instant;

use glam::{Affine3A, Vec3};
use rayon::prelude::*;
use shrad_scene::Role;
use shrad_sh::{
    cosine_lobe, cosine_lobe_sh, eval_basis, num_coeffs, trilinear_weights, ShRgb, MAX_COEFFS,
};
use shrad_vis::Hit;

use crate::direct::direct_irradiance;
use crate::energy::IncidentMeter;
use crate::probes::{ProbeCamera, Seen};
use crate::reference::{form_factor_rows, patch_rays};
use crate::{NoProgress, World};

/// Wall-exchange rows refreshed per frame (Step 4): at most this many, so a frame's cost does
/// not grow with the boundary beyond it (a 1M-patch room takes ~13 frames per full sweep).
pub const WALL_ROWS_PER_FRAME: usize = 1 << 16;

/// Rays per light patch for the energy meter's measure of what the lights absorb.
const LIGHT_METER_RAYS: usize = 16;

/// Which objects a frame updates (spec 4.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Schedule {
    /// Interior objects in order, `per_frame` a frame (paper: 1).
    RoundRobin {
        /// Objects per frame.
        per_frame: usize,
    },
    /// Highest priority first: staleness times a weight that grows when the object or a
    /// neighbour moved or a light changed; no object waits more than `max_staleness` frames.
    Priority {
        /// Objects per frame.
        per_frame: usize,
        /// Staleness bound in frames.
        max_staleness: usize,
    },
    /// As many objects (by priority) as fit in `ms` milliseconds; at least one.
    Budget {
        /// Per-frame time budget for Steps 2 and 3.
        ms: f32,
        /// Staleness bound in frames.
        max_staleness: usize,
    },
    /// Every object every frame: the same algorithm without dispersal.
    Full,
}

/// How a buried probe (one that sees mostly back faces) is handled (spec 4.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeRepair {
    /// Keep it (the paper).
    None,
    /// Drop it and renormalise the trilinear weights of the others.
    Drop,
    /// Move it along the box diagonal towards the centre until it is valid (else drop it).
    MoveInward,
}

/// How an object's reflected light reaches the boundary (Step 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToBoundary {
    /// Render a cube map of ids at the object's centre and splat each texel's flux on the
    /// boundary patch it sees (the paper).
    Splat,
    /// Evaluate the SH intensity towards every boundary patch, with one shadow ray each:
    /// the same point emitter without the cube map's aliasing.
    Gather,
    /// Gather while the boundary has fewer patches than twice a cube map's texels (and at
    /// least up to 32k patches), else splat: the cost of Step 3 then stays bounded however
    /// large the scene grows.
    Auto,
}

/// Settings of the dispersive solver. See [`DispersiveOptions::paper`] and
/// [`DispersiveOptions::improved`] (the default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DispersiveOptions {
    /// SH bands (paper: 4 = 16 coefficients).
    pub bands: usize,
    /// Cube-map face resolution of probes (paper: 128). The probes carry 16 SH
    /// coefficients of smooth, reflected light: 32 measured the same as 64 and 128 once
    /// direct light on interior objects is computed apart (docs/results.md).
    pub cube_res: usize,
    /// Cube-map face resolution of the Step 3 splat (paper: the probes' 128). The splat
    /// lands texels on boundary patches, so it needs more texels than a probe: at 32 an
    /// unsmoothed splat aliases (77k room: 8.2 % against 5.4 % at 64; docs/results.md §4).
    pub emitter_res: usize,
    /// Probe box margin as a fraction of the box diagonal (0: the paper's exact box).
    pub probe_margin: f32,
    /// The scheduler.
    pub schedule: Schedule,
    /// Back-face fraction above which a probe is invalid (DDGI: 0.25).
    pub invalid_back_fraction: f32,
    /// What to do with invalid probes.
    pub repair: ProbeRepair,
    /// Carry boundary-to-boundary light (precomputed sparse form factors among the static
    /// boundary patches, one Jacobi sweep per frame).
    pub wall_exchange: bool,
    /// Form-factor rays per boundary patch for the wall exchange.
    pub wall_rays: u32,
    /// Capture probes with the object's own geometry transparent (else its texels are 0).
    pub see_through_self: bool,
    /// Direct light on interior patches computed like the boundary's; probes then record only
    /// reflected light.
    pub direct_on_interior: bool,
    /// Shadow rays per (patch, emitter) for direct light.
    pub direct_samples: u32,
    /// Step 3 method.
    pub to_boundary: ToBoundary,
    /// Rays per interior patch that detect faces in contact with other surfaces (0: off,
    /// the paper). See `Dispersive::contact_openness`.
    pub contact_rays: u32,
    /// Step 3 with one SH emitter per face direction of the object (its patches grouped by
    /// the dominant axis of their rest-frame normal, each emitter at its group's centroid,
    /// lobes along the normals) instead of one at the centre: the floor beside a box is lit
    /// by the box's near face, not by a point in its middle.
    pub emitter_per_face: bool,
    /// Rays per interior patch for a precomputed transfer vector with self-visibility (the
    /// precomputed radiance transfer the paper cites): irradiance is the probe SH dotted
    /// with `T_i = ∫ V_self(w) max(0, n.w) Y(w) dw`, so a concave object shadows itself
    /// although its probes see through it, plus the light of the object's own patches seen
    /// in the blocked directions (self form factors). 0: the plain clamped-cosine lobe.
    pub self_shadow_rays: u32,
    /// Spread each boundary patch's splatted flux over the patch and its edge neighbours
    /// (patches sharing a smooth-shading vertex, so never across a crease), keeping the
    /// flux: the splat's texels and the patches are about the same size, so a patch gets
    /// 0, 1 or 2 texels and the raw splat is noisy (the paper's texel pattern).
    pub splat_smoothing: bool,
}

impl DispersiveOptions {
    /// The paper as written: exact box, no repair, no wall exchange, own texels black,
    /// direct light on interior objects through the probes, cube-map splat, K = 1.
    pub const fn paper() -> Self {
        DispersiveOptions {
            bands: 4,
            cube_res: 128,
            emitter_res: 128,
            probe_margin: 0.0,
            schedule: Schedule::RoundRobin { per_frame: 1 },
            invalid_back_fraction: 0.25,
            repair: ProbeRepair::None,
            wall_exchange: false,
            wall_rays: 64,
            see_through_self: false,
            direct_on_interior: false,
            direct_samples: 16,
            to_boundary: ToBoundary::Splat,
            contact_rays: 0,
            emitter_per_face: false,
            self_shadow_rays: 0,
            splat_smoothing: false,
        }
    }

    /// shrad's default: every improvement of spec 4.6 that measured better (docs/results.md).
    pub const fn improved() -> Self {
        DispersiveOptions {
            cube_res: 32,
            emitter_res: 64,
            probe_margin: 0.01,
            schedule: Schedule::Priority {
                per_frame: 1,
                max_staleness: 16,
            },
            repair: ProbeRepair::MoveInward,
            wall_exchange: true,
            see_through_self: true,
            direct_on_interior: true,
            to_boundary: ToBoundary::Auto,
            contact_rays: 8,
            emitter_per_face: true,
            self_shadow_rays: 64,
            splat_smoothing: true,
            ..Self::paper()
        }
    }
}

impl Default for DispersiveOptions {
    fn default() -> Self {
        Self::improved()
    }
}

/// The objects a frame updates. `#[must_use]`: a batch that is not applied is a bug.
#[must_use = "a scheduled batch must be lit (Step 2) and sent to the boundary (Step 3)"]
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Batch(pub Vec<usize>);

/// What changed in the world since the last frame (from [`World::set_time`]).
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// Objects whose transform changed.
    pub moved: Vec<usize>,
    /// Objects whose emission changed.
    pub relit: Vec<usize>,
}

pub use crate::energy::{Divergence, EnergyBalance};

/// Statistics of one frame (the paper's Table 3 columns and more).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// Frame index.
    pub frame: u64,
    /// Objects updated this frame.
    pub objects_updated: Vec<usize>,
    /// Step 1 time (ms).
    pub direct_ms: f64,
    /// Step 2 time (ms).
    pub objects_ms: f64,
    /// Step 3 time (ms).
    pub to_boundary_ms: f64,
    /// Step 4 time (ms).
    pub assemble_ms: f64,
    /// Whole frame (ms).
    pub frame_ms: f64,
    /// Frames since the stalest interior object was updated.
    pub stalest: u64,
    /// Probes found invalid among those captured this frame.
    pub probes_invalid: usize,
    /// Of those, repaired by moving.
    pub probes_repaired: usize,
    /// Flux balance.
    pub energy: EnergyBalance,
    /// Set when the state broke the energy bound or held non-finite values: what diverged
    /// and what was damped or reset (the published state is the repaired one).
    pub diverged: Option<Divergence>,
}

/// Per interior object: probe box, per-patch weights and exit directions (all in the rest
/// frame, invariant under rigid motion: paper 2.3.1 item 3).
struct ObjectProbes {
    object: usize,
    /// Box `(lo, hi)` in the object frame, margin included.
    lo: Vec3,
    hi: Vec3,
    /// Trilinear weights of each patch (object's patch range order).
    weights: Vec<[f32; 8]>,
    /// Exit direction of each patch in the object frame (paper 2.3.4 Step 1).
    exit_local: Vec<Vec3>,
    /// Frame of the last update (None: never).
    last_update: Option<u64>,
    /// Something near it changed since its last update.
    disturbed: f32,
    /// Measured ms of its last update.
    cost_ms: f64,
    /// Its current contribution to the boundary: (patch, irradiance).
    to_boundary: Vec<(u32, Vec3)>,
    /// Where each probe sits on the line from the box centre to its corner (1: the corner);
    /// repaired probes keep their place until the object moves.
    probe_scale: [f32; 8],
    /// Step 3 emitters: (centre in the object frame, offsets of its patches in the range).
    emitters: Vec<(Vec3, Vec<u32>)>,
    /// Per patch transfer vectors with self-visibility in the object frame (empty when off),
    /// `num_coeffs` floats each.
    transfer: Vec<f32>,
    /// Per patch, the object's own patches its blocked directions see, with their form
    /// factors: the light the object sends itself, which the transfer vector leaves out.
    self_view: Vec<Vec<(u32, f32)>>,
    /// Per patch, the contact openness (see `Dispersive::contact_openness`); empty until
    /// computed and again when the object or a neighbour moves (it is geometry only).
    openness: Vec<f32>,
}

impl ObjectProbes {
    /// Probe `c`'s position in the object frame (its corner, or moved inward if repaired).
    fn probe_local(&self, c: usize) -> Vec3 {
        let centre = self.centre_local();
        centre + (self.corner_local(c) - centre) * self.probe_scale[c]
    }
    fn corner_local(&self, c: usize) -> Vec3 {
        let s = Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
        self.lo + (self.hi - self.lo) * s
    }
    fn centre_local(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }
}

/// The dispersive solver's state.
pub struct Dispersive {
    options: DispersiveOptions,
    /// Step 2's probes.
    camera: ProbeCamera,
    /// Step 3's splat from each emitter.
    emitter_camera: ProbeCamera,
    objects: Vec<ObjectProbes>,
    /// Radiosity of every patch.
    radiosity: Vec<Vec3>,
    /// Direct irradiance (boundary, and interior when `direct_on_interior`).
    direct: Vec<Vec3>,
    /// Irradiance of interior patches from their probes.
    probe_irradiance: Vec<Vec3>,
    /// Sum over objects of their contributions to each boundary patch.
    indirect: Vec<Vec3>,
    /// One zero per patch: Step 3 sums its pieces here.
    scratch: Vec<Vec3>,
    /// Irradiance of boundary patches from other boundary patches.
    wall: Vec<Vec3>,
    /// Form-factor rows among boundary patches (aligned with `boundary_patches`), if the
    /// wall exchange is on.
    wall_rows: Option<Vec<Vec<(u32, f32)>>>,
    boundary_patches: Vec<u32>,
    /// Boundary patches next to each patch (itself included), for `splat_smoothing`.
    neighbours: Neighbours,
    /// World bounding box of every object at the last frame (to know where movers were).
    object_boxes: Vec<(Vec3, Vec3)>,
    /// Wall-exchange rows waiting to be re-traced.
    wall_dirty: Vec<bool>,
    /// Where the next frame's window of wall-exchange rows starts.
    wall_cursor: usize,
    direct_valid: bool,
    frame: u64,
    round_robin_next: usize,
    /// Irradiance of the lights that reflect nothing (kept at their emission), for the
    /// energy meter: what they absorb.
    light_meter: IncidentMeter,
    /// What this frame's guards found (moved into `FrameStats::diverged`).
    step_warnings: Vec<String>,
    /// Per patch: the side of a double-sided boundary surface that faces away from the
    /// scene's centre. A probe that sees it is outside the enclosure, like one that sees a
    /// single-sided back face (Blender exports every material double-sided by default, so
    /// without this a probe buried in the floor sees the floor's dark underside as valid).
    outer_side: Vec<bool>,
}

impl Dispersive {
    /// Precompute (paper 2.3.1): probe boxes, trilinear weights, exit directions, cube-map
    /// directions and SH weights; the wall exchange's form factors if enabled.
    pub fn new(world: &World, options: DispersiveOptions) -> Dispersive {
        let p = &world.patches;
        let camera = ProbeCamera::new(options.cube_res, options.bands);
        let emitter_camera = ProbeCamera::new(options.emitter_res, options.bands);
        let mut objects = Vec::new();
        for o in 0..world.scene.objects.len() {
            if p.object_role[o] != Role::Interior {
                continue;
            }
            let (mut lo, mut hi) = p.shapes[o].bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
            let margin = options.probe_margin.max(0.0) * (hi - lo).length();
            // A flat object still needs a box with volume.
            let pad =
                Vec3::splat(margin).max(Vec3::splat(1e-4 * (hi - lo).length().max(world.eps)));
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
            objects.push(ObjectProbes {
                object: o,
                lo,
                hi,
                weights,
                exit_local,
                last_update: None,
                disturbed: 1.0,
                cost_ms: 0.0,
                to_boundary: Vec::new(),
                probe_scale: [1.0; 8],
                emitters: emitter_groups(p, o, centre, options.emitter_per_face),
                transfer: Vec::new(),
                self_view: Vec::new(),
                openness: Vec::new(),
            });
        }
        for ob in &mut objects {
            (ob.transfer, ob.self_view) =
                self_transfer(world, ob.object, options.bands, options.self_shadow_rays);
        }
        let boundary_patches: Vec<u32> = (0..p.len() as u32)
            .filter(|&i| receives_as_boundary(world, i as usize))
            .collect();
        let wall_rows = options.wall_exchange.then(|| {
            // Every object occludes; only boundary-to-boundary entries are kept (light via
            // interior objects is Step 3's). Rows whose rays pass where an object moves are
            // re-traced then (see `refresh_wall_rows`).
            form_factor_rows(
                world,
                &boundary_patches,
                options.wall_rays,
                &[],
                |j| receives_as_boundary(world, j),
                &NoProgress,
            )
        });
        let object_boxes = (0..world.scene.objects.len())
            .map(|o| world_box(world, o))
            .collect();
        let n = p.len();
        let radiosity = world.exitance.clone();
        Dispersive {
            options,
            camera,
            emitter_camera,
            objects,
            radiosity,
            direct: vec![Vec3::ZERO; n],
            probe_irradiance: vec![Vec3::ZERO; n],
            indirect: vec![Vec3::ZERO; n],
            scratch: vec![Vec3::ZERO; n],
            wall: vec![Vec3::ZERO; n],
            neighbours: if options.splat_smoothing {
                Neighbours::of_boundary(world)
            } else {
                Neighbours::default()
            },
            wall_rows,
            wall_dirty: vec![false; boundary_patches.len()],
            wall_cursor: 0,
            boundary_patches,
            object_boxes,
            direct_valid: false,
            frame: 0,
            round_robin_next: 0,
            light_meter: IncidentMeter::new(
                world,
                (0..p.len() as u32)
                    .filter(|&i| {
                        p.role(i as usize) == Role::Light
                            && !receives_as_boundary(world, i as usize)
                    })
                    .collect(),
                LIGHT_METER_RAYS,
            ),
            step_warnings: Vec::new(),
            outer_side: outer_sides(world),
        }
    }

    /// Current radiosity of every patch.
    pub fn radiosity(&self) -> &[Vec3] {
        &self.radiosity
    }

    /// The options in use.
    pub fn options(&self) -> &DispersiveOptions {
        &self.options
    }

    /// Number of interior objects.
    pub fn interior_objects(&self) -> usize {
        self.objects.len()
    }

    /// Frames in which the scheduler updates every object once on a static scene.
    pub fn frames_per_pass(&self) -> usize {
        let n = self.objects.len().max(1);
        match self.options.schedule {
            Schedule::Full => 1,
            Schedule::RoundRobin { per_frame } | Schedule::Priority { per_frame, .. } => {
                n.div_ceil(per_frame.max(1))
            }
            Schedule::Budget { .. } => n,
        }
    }

    /// One frame (paper 2.2): the world is already at the frame's time; `changes` says what
    /// moved or changed emission since the previous frame.
    pub fn step(&mut self, world: &World, changes: &Changes) -> FrameStats {
        let frame_start = Instant::now();
        let mut stats = FrameStats {
            frame: self.frame,
            ..Default::default()
        };
        self.note_changes(world, changes);

        let t = Instant::now();
        let swept = self.swept_boxes(world, changes);
        self.direct_to_boundary(world, changes, &swept);
        self.refresh_wall_rows(world, &swept);
        stats.direct_ms = ms(t);

        let batch = self.schedule();
        let t = Instant::now();
        let lit = self.light_selected_objects(world, batch, &mut stats);
        stats.objects_ms = ms(t);

        let t = Instant::now();
        stats.energy.object_emitters = self.objects_to_boundary(world, lit);
        stats.to_boundary_ms = ms(t);

        let t = Instant::now();
        let sweeps = if changes.relit.is_empty() { 1 } else { 8 };
        self.assemble(world, sweeps);
        stats.assemble_ms = ms(t);

        // The energy meter, and the guard that never publishes a diverged state.
        if !changes.moved.is_empty() {
            self.light_meter.retrace(world);
        }
        stats.energy = EnergyBalance {
            object_emitters: stats.energy.object_emitters,
            ..self.energy(world)
        };
        let earlier = (!self.step_warnings.is_empty()).then(|| Divergence {
            message: std::mem::take(&mut self.step_warnings).join("; "),
            non_finite: 0,
        });
        if let Some(d) = self.guard(world, &stats.energy, earlier) {
            stats.energy = EnergyBalance {
                object_emitters: stats.energy.object_emitters,
                ..self.energy(world)
            };
            stats.diverged = Some(d);
        }

        stats.frame_ms = ms(frame_start);
        stats.stalest = self
            .objects
            .iter()
            .map(|o| o.last_update.map_or(self.frame + 1, |f| self.frame - f))
            .max()
            .unwrap_or(0);
        self.frame += 1;
        stats
    }

    /// Reset non-finite values and damp a state that breaks the energy bound (spec 2): the
    /// reflected part of every radiosity, and every irradiance that feeds it, is scaled back
    /// to the bound. Returns what diverged, with the largest object emitter named, merged
    /// with `earlier` (what Step 3's own guard found this frame).
    fn guard(
        &mut self,
        world: &World,
        balance: &EnergyBalance,
        earlier: Option<Divergence>,
    ) -> Option<Divergence> {
        let mut non_finite = 0;
        for v in [
            &mut self.radiosity,
            &mut self.direct,
            &mut self.probe_irradiance,
            &mut self.indirect,
            &mut self.wall,
        ] {
            non_finite += crate::energy::reset_non_finite(v);
        }
        for ob in &mut self.objects {
            for (_, e) in &mut ob.to_boundary {
                if !e.is_finite() {
                    *e = Vec3::ZERO;
                    non_finite += 1;
                }
            }
        }
        let scale = crate::energy::over_bound(balance);
        if scale.is_none() && non_finite == 0 {
            return earlier;
        }
        let mut message = earlier.map(|d| d.message + "; ").unwrap_or_default();
        if non_finite > 0 {
            message += &format!("{non_finite} non-finite value(s) reset to 0");
        }
        if let Some(s) = scale {
            let largest = self
                .objects
                .iter()
                .map(|ob| {
                    let flux: f64 = ob
                        .to_boundary
                        .iter()
                        .map(|&(j, e)| (e * world.patches.area[j as usize]).element_sum() as f64)
                        .sum();
                    (flux / 3.0, ob.object)
                })
                .max_by(|a, b| a.0.total_cmp(&b.0));
            if non_finite > 0 {
                message += "; ";
            }
            message += &format!(
                "reflected flux {:.4e} exceeds the bound {:.4e} that the lights can sustain",
                balance.reflected, balance.reflected_bound
            );
            if let Some((flux, o)) = largest {
                message += &format!(
                    " (largest object emitter: '{}', {flux:.4e} sent to the boundary)",
                    world.scene.objects[o].name
                );
            }
            message += &format!("; reflected light damped by {s:.3}");
            let s = s as f32;
            // Direct light too (it may be what overshoots, on patches measured wrongly); it
            // is recomputed next frame rather than damped again on top of this.
            self.direct_valid = false;
            for v in [
                &mut self.direct,
                &mut self.probe_irradiance,
                &mut self.indirect,
                &mut self.wall,
            ] {
                v.iter_mut().for_each(|e| *e *= s);
            }
            for ob in &mut self.objects {
                ob.to_boundary.iter_mut().for_each(|(_, e)| *e *= s);
            }
            for (i, b) in self.radiosity.iter_mut().enumerate() {
                let m = world.exitance[i];
                *b = m + (*b - m) * s;
            }
        }
        Some(Divergence {
            message,
            non_finite,
        })
    }

    /// Mark objects near what moved (or every object, when a light changed) as disturbed.
    fn note_changes(&mut self, world: &World, changes: &Changes) {
        let p = &world.patches;
        let lights_changed = changes
            .relit
            .iter()
            .chain(&changes.moved)
            .any(|&o| p.object_role[o] == Role::Light);
        let boxes: Vec<(Vec3, f32)> = changes
            .moved
            .iter()
            .filter_map(|&o| {
                let r = p.range(o);
                let pts = r.map(|i| p.centre[i]);
                let (lo, hi) = pts.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), c| {
                    (a.min(c), b.max(c))
                });
                lo.is_finite()
                    .then(|| (0.5 * (lo + hi), 0.5 * (hi - lo).length()))
            })
            .collect();
        for ob in &mut self.objects {
            if changes.moved.contains(&ob.object) {
                ob.disturbed = ob.disturbed.max(4.0);
                // Its surroundings changed: probes go back to the corners and are re-checked.
                ob.probe_scale = [1.0; 8];
                ob.openness.clear();
                continue;
            }
            if lights_changed {
                ob.disturbed = ob.disturbed.max(2.0);
            }
            let m = p.world_from_local[ob.object];
            let c = m.transform_point3(ob.centre_local());
            let r = 0.5 * m.transform_vector3(ob.hi - ob.lo).length();
            // A neighbour: within three times the two radii.
            if boxes
                .iter()
                .any(|(bc, br)| (c - *bc).length() < 3.0 * (r + br))
            {
                ob.disturbed = ob.disturbed.max(2.0);
                ob.openness.clear();
            }
        }
    }

    /// Boxes swept by the objects that moved since the last frame (old and new positions),
    /// as bounding spheres; updates the remembered boxes.
    fn swept_boxes(&mut self, world: &World, changes: &Changes) -> Vec<(Vec3, Vec3)> {
        let mut swept = Vec::new();
        for &o in &changes.moved {
            let old = self.object_boxes[o];
            let new = world_box(world, o);
            swept.push(old);
            swept.push(new);
            self.object_boxes[o] = new;
        }
        swept
    }

    /// Step 1 (paper 2.3.2): direct light on the boundary (and interior patches when
    /// `direct_on_interior`). The paper recomputes it every frame; here it is cached and
    /// recomputed only for the patches whose view of a light an object's motion may have
    /// changed (all of them when a light moved or changed).
    fn direct_to_boundary(&mut self, world: &World, changes: &Changes, swept: &[(Vec3, Vec3)]) {
        if self.direct_valid && changes.moved.is_empty() && changes.relit.is_empty() {
            return;
        }
        let p = &world.patches;
        let light_changed = !changes.relit.is_empty()
            || changes.moved.iter().any(|&o| {
                p.object_role[o] == Role::Light
                    || world.exitance[p.range(o).start].max_element() > 0.0
            });
        let everything = !self.direct_valid || light_changed;
        let lights: Vec<(Vec3, f32)> = if everything {
            Vec::new()
        } else {
            (0..world.scene.objects.len())
                .filter(|&o| {
                    !p.range(o).is_empty() && world.exitance[p.range(o).start].max_element() > 0.0
                })
                .map(|o| sphere(world_box(world, o)))
                .collect()
        };
        let movers: Vec<(Vec3, f32)> = swept.iter().map(|&b| sphere(b)).collect();
        let receivers: Vec<u32> = (0..p.len() as u32)
            .into_par_iter()
            .filter(|&i| match p.role(i as usize) {
                Role::Boundary | Role::Light => true,
                Role::Interior => self.options.direct_on_interior,
            })
            .filter(|&i| world.reflectance[i as usize].max_element() > 0.0)
            .filter(|&i| {
                everything || {
                    let x = p.centre[i as usize];
                    lights.iter().any(|&(lc, lr)| {
                        movers
                            .iter()
                            .any(|&(bc, br)| cone_meets_sphere(x, lc, lr, bc, br))
                    })
                }
            })
            .collect();
        // Interior patches of a moved object always need it (they moved).
        let mut receivers = receivers;
        if !everything && self.options.direct_on_interior {
            for &o in &changes.moved {
                receivers.extend(p.range(o).map(|i| i as u32));
            }
            receivers.sort_unstable();
            receivers.dedup();
        }
        let e = direct_irradiance(world, &receivers, self.options.direct_samples);
        for (&i, e) in receivers.iter().zip(e) {
            self.direct[i as usize] = e;
        }
        self.direct_valid = true;
    }

    /// Mark the wall-exchange rows whose rays pass through a box an object swept, and
    /// re-trace the stalest dirty rows, at most an eighth of the boundary per frame (the
    /// dispersive idea applied to the walls: the cost of a frame stays bounded).
    fn refresh_wall_rows(&mut self, world: &World, swept: &[(Vec3, Vec3)]) {
        let Some(rows) = &mut self.wall_rows else {
            return;
        };
        let p = &world.patches;
        let rays = self.options.wall_rays.max(1) as usize;
        if !swept.is_empty() {
            let boundary = &self.boundary_patches;
            let newly: Vec<usize> = (0..boundary.len())
                .into_par_iter()
                .filter(|&k| !self.wall_dirty[k])
                .filter(|&k| {
                    let i = boundary[k] as usize;
                    let (c, n) = (p.centre[i], p.normal[i]);
                    // A box wholly behind the patch cannot meet its rays.
                    let in_front = swept.iter().any(|&(lo, hi)| {
                        let (bc, br) = sphere((lo, hi));
                        n.dot(bc - c) > -br
                    });
                    if !in_front {
                        return false;
                    }
                    let mut o = vec![Vec3::ZERO; rays];
                    let mut d = vec![Vec3::ZERO; rays];
                    patch_rays(world, i, &mut o, &mut d);
                    o.iter()
                        .zip(&d)
                        .any(|(o, d)| swept.iter().any(|&(lo, hi)| ray_meets_box(*o, *d, lo, hi)))
                })
                .collect();
            for k in newly {
                self.wall_dirty[k] = true;
            }
        }
        let budget = self.boundary_patches.len().div_ceil(8).max(1);
        let dirty: Vec<usize> = (0..self.boundary_patches.len())
            .filter(|&k| self.wall_dirty[k])
            .take(budget)
            .collect();
        if dirty.is_empty() {
            return;
        }
        let ids: Vec<u32> = dirty.iter().map(|&k| self.boundary_patches[k]).collect();
        let fresh = form_factor_rows(
            world,
            &ids,
            rays as u32,
            &[],
            |j| receives_as_boundary(world, j),
            &NoProgress,
        );
        for (k, row) in dirty.into_iter().zip(fresh) {
            rows[k] = row;
            self.wall_dirty[k] = false;
        }
    }

    /// The scheduler (spec 4.3): which interior objects this frame updates.
    fn schedule(&mut self) -> Batch {
        let n = self.objects.len();
        if n == 0 {
            return Batch(Vec::new());
        }
        let frame = self.frame;
        let staleness = |o: &ObjectProbes| o.last_update.map_or(u64::MAX / 4, |f| frame - f) as f64;
        match self.options.schedule {
            Schedule::Full => Batch((0..n).collect()),
            Schedule::RoundRobin { per_frame } => {
                let k = per_frame.clamp(1, n);
                let picked = (0..k).map(|j| (self.round_robin_next + j) % n).collect();
                self.round_robin_next = (self.round_robin_next + k) % n;
                Batch(picked)
            }
            Schedule::Priority {
                per_frame,
                max_staleness,
            } => {
                let k = per_frame.clamp(1, n);
                Batch(
                    self.by_priority(max_staleness, &staleness)
                        .into_iter()
                        .take(k)
                        .collect(),
                )
            }
            Schedule::Budget { ms, max_staleness } => {
                let order = self.by_priority(max_staleness, &staleness);
                let mut spent = 0.0;
                let mut picked = Vec::new();
                for o in order {
                    let cost = self.objects[o].cost_ms.max(0.01);
                    if !picked.is_empty() && spent + cost > ms as f64 {
                        break;
                    }
                    spent += cost;
                    picked.push(o);
                }
                Batch(picked)
            }
        }
    }

    /// Objects in decreasing priority: over-stale objects first, then staleness x weight.
    fn by_priority(
        &self,
        max_staleness: usize,
        staleness: &dyn Fn(&ObjectProbes) -> f64,
    ) -> Vec<usize> {
        let mut order: Vec<(usize, f64)> = self
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let s = staleness(o);
                let forced = if s >= max_staleness as f64 { 1e12 } else { 0.0 };
                (i, forced + (s + 1.0) * o.disturbed as f64)
            })
            .collect();
        order.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        order.into_iter().map(|(i, _)| i).collect()
    }

    /// Step 2 (paper 2.3.3): light each object of the batch from its 8 corner probes.
    fn light_selected_objects(
        &mut self,
        world: &World,
        batch: Batch,
        stats: &mut FrameStats,
    ) -> Vec<usize> {
        let p = &world.patches;
        let bands = self.options.bands;
        let nc = num_coeffs(bands);
        for &k in &batch.0 {
            let t = Instant::now();
            let ob = &self.objects[k];
            let o = ob.object;
            let m = p.world_from_local[o];
            let (probes, scale) = self.capture_corner_probes(world, k, m, stats);
            self.objects[k].probe_scale = scale;
            let range = p.range(o);
            let ob = &self.objects[k];
            let with_transfer = !ob.transfer.is_empty();
            // With transfer vectors (object frame) the probes are rotated into the object's
            // frame once: rotation is linear, so this equals rotating every patch's
            // interpolated SH.
            let probes: Vec<Option<ShRgb>> = if with_transfer {
                let (_, rotation, _) = m.to_scale_rotation_translation();
                let to_local = shrad_sh::ShRotation::from_quat(bands, rotation.inverse());
                probes
                    .iter()
                    .map(|sh| {
                        sh.as_ref().map(|sh| {
                            let mut local = ShRgb::zeros(bands);
                            to_local.rotate_rgb(sh, &mut local);
                            local
                        })
                    })
                    .collect()
            } else {
                probes
            };
            let e: Vec<Vec3> = range
                .clone()
                .into_par_iter()
                .map(|i| {
                    let k = i - range.start;
                    let w = ob.weights[k];
                    // Interpolate the probes to the patch (paper 2.3.3, trilinear weights,
                    // renormalised over the valid probes).
                    let mut l = [Vec3::ZERO; MAX_COEFFS];
                    let mut sum_w = 0.0;
                    for (sh, &wc) in probes.iter().zip(&w) {
                        if let Some(sh) = sh {
                            for (a, &b) in l[..nc].iter_mut().zip(sh.coeffs()) {
                                *a += b * wc;
                            }
                            sum_w += wc;
                        }
                    }
                    if sum_w <= 0.0 {
                        return Vec3::ZERO;
                    }
                    // Dot with the patch's transfer vector (object frame), or with the
                    // clamped-cosine lobe of its world normal.
                    let mut lobe = [0f32; MAX_COEFFS];
                    let weights: &[f32] = if with_transfer {
                        &ob.transfer[k * nc..(k + 1) * nc]
                    } else {
                        cosine_lobe_sh(bands, p.normal[i], &mut lobe[..nc]);
                        &lobe[..nc]
                    };
                    let dot: Vec3 = l[..nc].iter().zip(weights).map(|(a, &b)| *a * b).sum();
                    // The object's own light in the directions it blocks (self form factors).
                    let own: Vec3 = if with_transfer {
                        ob.self_view[k]
                            .iter()
                            .map(|&(q, f)| {
                                let q = range.start + q as usize;
                                (self.radiosity[q] - world.exitance[q]) * f
                            })
                            .sum()
                    } else {
                        Vec3::ZERO
                    };
                    (dot / sum_w).max(Vec3::ZERO) + own
                })
                .collect();
            if self.objects[k].openness.len() != range.len() {
                self.objects[k].openness = if self.options.contact_rays > 0 {
                    self.contact_openness(world, k)
                } else {
                    vec![1.0; range.len()]
                };
            }
            let openness = &self.objects[k].openness;
            for ((i, e), &v) in range.clone().zip(e).zip(openness) {
                let e = e * v;
                self.probe_irradiance[i] = e;
                let direct = if self.options.direct_on_interior {
                    self.direct[i]
                } else {
                    Vec3::ZERO
                };
                self.radiosity[i] = world.exitance[i] + world.reflectance[i] * (e + direct);
            }
            let ob = &mut self.objects[k];
            ob.last_update = Some(self.frame);
            ob.disturbed = 1.0;
            ob.cost_ms = ms(t);
            stats.objects_updated.push(o);
        }
        batch.0
    }

    /// Per patch of object `k`, the (cosine-weighted) fraction of its hemisphere that is not
    /// closed off right in front of it: rays start just *inside* the surface (the object
    /// itself transparent) and look for anything within 2 % of the object's box diagonal.
    /// A face resting on the floor gets 0 — the probes, a box-size apart, cannot see that
    /// contact and would light it with the floor's radiance.
    fn contact_openness(&self, world: &World, k: usize) -> Vec<f32> {
        let p = &world.patches;
        let ob = &self.objects[k];
        let o = ob.object;
        let m = p.world_from_local[o];
        let reach = 0.02 * m.transform_vector3(ob.hi - ob.lo).length();
        let rays = self.options.contact_rays as usize;
        let range = p.range(o);
        let mut origins = vec![Vec3::ZERO; range.len() * rays];
        let mut dirs = vec![Vec3::ZERO; range.len() * rays];
        origins
            .par_chunks_mut(rays)
            .zip(dirs.par_chunks_mut(rays))
            .enumerate()
            .for_each(|(k, (org, dir))| {
                let i = range.start + k;
                let n = p.normal[i];
                let shift = (crate::sampling::unit(crate::sampling::hash(i as u32)), 0.5);
                for j in 0..rays {
                    let (u, v) = crate::sampling::hammersley(j as u32, rays as u32, shift);
                    org[j] = p.centre[i] - n * world.eps;
                    dir[j] = crate::sampling::square_to_cosine_hemisphere(u, v, n);
                }
            });
        let mut hits = vec![Hit::MISS; origins.len()];
        world
            .vis
            .closest(&origins, &dirs, 0.0, &[o as u32], &mut hits);
        hits.chunks(rays)
            .map(|h| {
                h.iter().filter(|h| !(h.is_hit() && h.t <= reach)).count() as f32 / rays as f32
            })
            .collect()
    }

    /// Capture the 8 probes of object `k`; `None` for a probe dropped as invalid.
    fn capture_corner_probes(
        &self,
        world: &World,
        k: usize,
        m: Affine3A,
        stats: &mut FrameStats,
    ) -> (Vec<Option<ShRgb>>, [f32; 8]) {
        let ob = &self.objects[k];
        let o = ob.object as u32;
        let exclude: Vec<u32> = if self.options.see_through_self {
            vec![o]
        } else {
            vec![]
        };
        let points: Vec<Vec3> = (0..8)
            .map(|c| m.transform_point3(ob.probe_local(c)))
            .collect();
        let shade = |h: &Hit| self.shade_probe_texel(world, h, o);
        let captured = self.camera.capture(world, &points, &exclude, shade);
        let limit = self.options.invalid_back_fraction;
        let mut out: Vec<Option<ShRgb>> = captured.sh.into_iter().map(Some).collect();
        let mut scale = ob.probe_scale;
        for c in 0..8 {
            if captured.back_fraction[c] <= limit {
                continue;
            }
            stats.probes_invalid += 1;
            match self.options.repair {
                ProbeRepair::None => {}
                ProbeRepair::Drop => out[c] = None,
                ProbeRepair::MoveInward => {
                    out[c] = None;
                    let centre = ob.centre_local();
                    for s in [0.8f32, 0.6, 0.4, 0.2]
                        .into_iter()
                        .filter(|&s| s < scale[c])
                    {
                        let q = m.transform_point3(centre + (ob.corner_local(c) - centre) * s);
                        let again = self.camera.capture(world, &[q], &exclude, shade);
                        if again.back_fraction[0] <= limit {
                            out[c] = again.sh.into_iter().next();
                            scale[c] = s;
                            stats.probes_repaired += 1;
                            break;
                        }
                    }
                }
            }
        }
        (out, scale)
    }

    /// Radiance a probe texel of object `o` sees (paper 2.3.3: its own texels are 0).
    fn shade_probe_texel(&self, world: &World, h: &Hit, o: u32) -> Seen {
        if !h.is_hit() {
            return Seen::Radiance(Vec3::ZERO);
        }
        if h.object == o {
            // Only reached when the object is not transparent: the paper's black self.
            return Seen::Radiance(Vec3::ZERO);
        }
        let Some(j) = world.seen_patch(h) else {
            return Seen::BackFace;
        };
        if self.outer_side[j] {
            // The outside of a double-sided enclosure: the probe is outside the scene.
            return Seen::BackFace;
        }
        let b = if self.options.direct_on_interior {
            // Direct light is added apart; the probe carries reflected light only.
            self.radiosity[j] - world.exitance[j]
        } else {
            self.radiosity[j]
        };
        Seen::Radiance(b * std::f32::consts::FRAC_1_PI)
    }

    /// Step 3 (paper 2.3.4): each lit object sends its reflected light to the boundary as one
    /// SH emitter at its centre, replacing its previous contribution. Returns the flux sent.
    fn objects_to_boundary(&mut self, world: &World, lit: Vec<usize>) -> f64 {
        let p = &world.patches;
        let bands = self.options.bands;
        let nc = num_coeffs(bands);
        let mut flux_sent = 0.0;
        for k in lit {
            let ob = &self.objects[k];
            let o = ob.object;
            let m = p.world_from_local[o];
            let range = p.range(o);
            let method = match self.options.to_boundary {
                // Gather while it costs about what a splat does (up to 2 x 6R^2 boundary
                // patches, and at least up to 32k: a coarse splat aliases), splat beyond, so
                // that the cost of Step 3 stays bounded however large the boundary grows.
                ToBoundary::Auto
                    if self.boundary_patches.len()
                        > (2 * self.emitter_camera.texels()).max(1 << 15) =>
                {
                    ToBoundary::Splat
                }
                ToBoundary::Auto => ToBoundary::Gather,
                m => m,
            };
            // Pieces (boundary patch, value), several per patch: irradiance from a gather,
            // flux from a splat.
            let mut pieces: Vec<(u32, Vec3)> = Vec::new();
            for (centre_local, members) in &ob.emitters {
                let centre = m.transform_point3(*centre_local);
                // Outgoing intensity in SH: sum_i (rho_i E_i) A_i / pi * A_l Y_k(d_i).
                let mut intensity = vec![Vec3::ZERO; nc];
                let mut basis = [0f32; 64];
                for &k in members {
                    let i = range.start + k as usize;
                    let reflected = self.radiosity[i] - world.exitance[i];
                    let local = if self.options.emitter_per_face {
                        p.normal_local[i]
                    } else {
                        ob.exit_local[k as usize]
                    };
                    let d = m.transform_vector3(local).normalize_or_zero();
                    eval_basis(bands, d, &mut basis[..nc]);
                    let scale = reflected * p.area[i] * std::f32::consts::FRAC_1_PI;
                    for c in 0..nc {
                        intensity[c] += scale * (cosine_lobe(shrad_sh::band_of(c)) * basis[c]);
                    }
                }
                let intensity = ShRgb::from_coeffs(intensity);
                pieces.extend(match method {
                    ToBoundary::Splat | ToBoundary::Auto => {
                        self.splat(world, o, centre, &intensity)
                    }
                    ToBoundary::Gather => {
                        let soften = if self.options.emitter_per_face {
                            members
                                .iter()
                                .map(|&k| p.area[range.start + k as usize])
                                .sum::<f32>()
                                * std::f32::consts::FRAC_1_PI
                        } else {
                            0.0
                        };
                        self.gather(world, o, centre, &intensity, soften)
                    }
                });
            }
            let contribution = match method {
                ToBoundary::Gather => sum_by_patch(&mut self.scratch, pieces),
                _ if self.options.splat_smoothing => {
                    // Each patch's flux spread over its neighbourhood in proportion to area.
                    let flux = sum_by_patch(&mut self.scratch, pieces);
                    let near = &self.neighbours;
                    let spread = flux.iter().flat_map(|&(k, f)| {
                        let w = f * near.inv_area[k as usize];
                        near.of(k as usize).iter().map(move |&i| (i, w))
                    });
                    sum_by_patch(&mut self.scratch, spread)
                }
                _ => {
                    let by_area = pieces.into_iter().map(|(j, f)| (j, f / p.area[j as usize]));
                    sum_by_patch(&mut self.scratch, by_area)
                }
            };
            // An object cannot send the boundary more than it reflects: a contribution beyond
            // that (patches measured in the wrong units, a splat that aliases) is damped to
            // it, and the frame says so.
            let reflected: f64 = range
                .clone()
                .map(|i| ((self.radiosity[i] - world.exitance[i]) * p.area[i]).element_sum() as f64)
                .sum::<f64>()
                / 3.0;
            let sent: f64 = contribution
                .iter()
                .map(|&(j, e)| (e * p.area[j as usize]).element_sum() as f64)
                .sum::<f64>()
                / 3.0;
            let mut contribution = contribution;
            let within = sent <= reflected * crate::energy::BOUND_TOLERANCE + f64::MIN_POSITIVE;
            if !within {
                let s = if sent.is_finite() && sent > 0.0 {
                    (reflected.max(0.0) / sent) as f32
                } else {
                    0.0
                };
                contribution.iter_mut().for_each(|(_, e)| *e *= s);
                let note = format!(
                    "object '{}' sent {sent:.4e} to the boundary but reflects only {reflected:.4e}: its contribution was damped by {s:.3}",
                    world.scene.objects[o].name
                );
                self.step_warnings.push(note);
            }
            // Replace the object's previous contribution (paper: "只更新当前物体对它的影响").
            for &(j, e) in &self.objects[k].to_boundary {
                self.indirect[j as usize] -= e;
            }
            for &(j, e) in &contribution {
                self.indirect[j as usize] += e;
                flux_sent += (e * p.area[j as usize]).element_sum() as f64 / 3.0;
            }
            self.objects[k].to_boundary = contribution;
        }
        flux_sent
    }

    /// The paper's Step 3 from one emitter: see [`splat_to_boundary`].
    fn splat(&self, world: &World, o: usize, centre: Vec3, intensity: &ShRgb) -> Vec<(u32, Vec3)> {
        splat_to_boundary(world, &self.emitter_camera, o as u32, centre, intensity)
    }

    /// Point-emitter gather: `E_j = I(w_j) cos_j / r^2`, one shadow ray per boundary patch
    /// the emitter sends light to.
    ///
    /// `soften` (an area / pi) regularises `1 / r^2` near an extended emitter, as for a disc:
    /// `cos / (r^2 + soften)` (on a disc's axis this is exact).
    fn gather(
        &self,
        world: &World,
        o: usize,
        centre: Vec3,
        intensity: &ShRgb,
        soften: f32,
    ) -> Vec<(u32, Vec3)> {
        let p = &world.patches;
        // Unoccluded irradiance with the softened and the plain 1 / r^2; the softened one is
        // rescaled to the plain one's total flux, so softening moves light but neither adds
        // nor loses any. Patches facing away or behind the emitter's lobe get no ray.
        let lit: Vec<(u32, Vec3, f32, f32)> = self
            .boundary_patches
            .par_iter()
            .filter_map(|&j| {
                let d = centre - p.centre[j as usize];
                let r2 = d.length_squared().max(1e-12);
                let towards_object = d / r2.sqrt();
                let cos = p.normal[j as usize].dot(towards_object);
                if cos <= 0.0 {
                    return None;
                }
                let e = intensity.eval(-towards_object).max(Vec3::ZERO) * cos;
                let a = p.area[j as usize];
                (e.max_element() > 0.0).then_some((
                    j,
                    e / (r2 + soften),
                    a * e.element_sum() / r2,
                    a * e.element_sum() / (r2 + soften),
                ))
            })
            .collect();
        let from: Vec<Vec3> = lit
            .iter()
            .map(|&(j, ..)| p.centre[j as usize] + p.normal[j as usize] * world.eps)
            .collect();
        let to = vec![centre; lit.len()];
        let mut blocked = vec![false; lit.len()];
        world
            .vis
            .occluded(&from, &to, world.eps, &[o as u32], &mut blocked);
        let (plain, softened) = lit
            .iter()
            .zip(&blocked)
            .filter(|(_, &b)| !b)
            .fold((0f64, 0f64), |(x, y), (e, _)| {
                (x + e.2 as f64, y + e.3 as f64)
            });
        let scale = if softened > 0.0 {
            (plain / softened) as f32
        } else {
            1.0
        };
        lit.into_iter()
            .zip(blocked)
            .filter(|(_, b)| !b)
            .map(|((j, e, _, _), _)| (j, e * scale))
            .collect()
    }

    /// Step 4 (paper 2.3.5): boundary radiosity from direct, object and wall light.
    ///
    /// The boundary's own exchange takes one Jacobi sweep per frame over at most
    /// [`WALL_ROWS_PER_FRAME`] rows (a window that moves round the boundary, so the cost of a
    /// frame stays bounded on large scenes: the dispersive idea applied to the walls), or
    /// `sweeps` full sweeps when the light changed (the walls then converge in that frame).
    fn assemble(&mut self, world: &World, sweeps: usize) {
        let p = &world.patches;
        let n = self.boundary_patches.len();
        for _ in 0..sweeps.max(1) {
            if let Some(rows) = &self.wall_rows {
                let window = if sweeps > 1 {
                    n
                } else {
                    n.min(WALL_ROWS_PER_FRAME)
                };
                let start = self.wall_cursor % n.max(1);
                let ks: Vec<usize> = (0..window).map(|k| (start + k) % n).collect();
                self.wall_cursor = (start + window) % n.max(1);
                // Reflected light of every patch first: one random read per row entry.
                let reflected: Vec<Vec3> = self
                    .radiosity
                    .par_iter()
                    .zip(&world.exitance)
                    .map(|(b, e)| *b - *e)
                    .collect();
                let wall: Vec<Vec3> = ks
                    .par_iter()
                    .map(|&k| {
                        rows[k]
                            .iter()
                            .map(|&(j, f)| reflected[j as usize] * f)
                            .sum()
                    })
                    .collect();
                for (&k, w) in ks.iter().zip(wall) {
                    self.wall[self.boundary_patches[k] as usize] = w;
                }
            }
            for &j in &self.boundary_patches {
                let j = j as usize;
                self.radiosity[j] = world.exitance[j]
                    + world.reflectance[j] * (self.direct[j] + self.indirect[j] + self.wall[j]);
            }
            if self.wall_rows.is_none() {
                break;
            }
        }
        // Lights that reflect nothing are their emission (reflective ones are boundary).
        for (o, role) in p.object_role.iter().enumerate() {
            if *role == Role::Light {
                for i in p.range(o).filter(|&i| !receives_as_boundary(world, i)) {
                    self.radiosity[i] = world.exitance[i];
                }
            }
        }
    }

    /// Flux balance of the current state, the lights' absorption included.
    fn energy(&self, world: &World) -> EnergyBalance {
        let p = &world.patches;
        let mut irradiance: Vec<Vec3> = (0..p.len())
            .map(|i| match p.role(i) {
                Role::Interior => {
                    self.probe_irradiance[i]
                        + if self.options.direct_on_interior {
                            self.direct[i]
                        } else {
                            Vec3::ZERO
                        }
                }
                _ => self.direct[i] + self.indirect[i] + self.wall[i],
            })
            .collect();
        self.light_meter.measure(&self.radiosity, &mut irradiance);
        crate::energy::balance(world, &irradiance, |i| {
            p.role(i) != Role::Light || receives_as_boundary(world, i)
        })
    }

    /// Run frames on a static world until every object was updated `passes` times.
    pub fn converge(&mut self, world: &World, passes: usize) -> Vec<FrameStats> {
        let frames = passes * self.objects.len().max(1);
        let mut changes = Changes::default();
        (0..frames)
            .map(|_| {
                let s = self.step(world, &changes);
                changes = Changes::default();
                s
            })
            .collect()
    }
}

/// The paper's Step 3 (2.3.4) from one SH emitter: a cube map of `camera` at `centre` (object
/// `own` transparent), each texel's flux (intensity times solid angle) onto the boundary
/// patch it sees. Returns one (patch, flux) piece per texel that lands on the boundary; the
/// rest of the flux leaves through the scene's openings or lands on other objects.
pub fn splat_to_boundary(
    world: &World,
    camera: &ProbeCamera,
    own: u32,
    centre: Vec3,
    intensity: &ShRgb,
) -> Vec<(u32, Vec3)> {
    let (cube, projector) = (&camera.cube, &camera.projector);
    // Only texels the emitter sends light into are traced: a face emitter's lobe is zero
    // over the half of the sphere behind it. (Flux through a texel: the intensity times the
    // texel's solid angle, read off the projector's table without evaluating Y_k.)
    let flux: Vec<(usize, Vec3)> = (0..cube.directions.len())
        .into_par_iter()
        .filter_map(|t| {
            let f = projector.texel_value(intensity, t).max(Vec3::ZERO);
            (f.max_element() > 0.0).then_some((t, f))
        })
        .collect();
    let dirs: Vec<Vec3> = flux.iter().map(|&(t, _)| cube.directions[t]).collect();
    let mut hits = vec![Hit::MISS; dirs.len()];
    // Still in texel order, so the capture's ray packets stay coherent.
    world.vis.capture(&[centre], &dirs, 0.0, &[own], &mut hits);
    hits.iter()
        .zip(&flux)
        .filter_map(|(h, &(_, f))| {
            let j = world.seen_patch(h)?;
            receives_as_boundary(world, j).then_some((j as u32, f))
        })
        .collect()
}

/// Whether patch `i` is lit like the boundary (Steps 1, 3, 4 and the wall exchange): the
/// boundary's patches, and those of lights that also reflect (a lamp panel, an emissive
/// card: the paper's lights only emit, but a reflective emitter near a wall otherwise
/// loses the light it bounces back).
/// See `Dispersive::outer_side`.
fn outer_sides(world: &World) -> Vec<bool> {
    let p = &world.patches;
    let (lo, hi) = world.scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let centre = 0.5 * (lo + hi);
    (0..p.len())
        .map(|i| {
            p.role(i) == Role::Boundary
                && p.twin[i] != crate::patches::NO_PATCH
                && p.normal[i].dot(centre - p.centre[i]) < 0.0
        })
        .collect()
}

fn receives_as_boundary(world: &World, i: usize) -> bool {
    match world.patches.role(i) {
        Role::Boundary => true,
        Role::Light => world.reflectance[i].max_element() > 0.0,
        Role::Interior => false,
    }
}

/// Boundary patches around each boundary patch: those sharing one of its smooth-shading
/// vertices (corners welded by position within the crease angle), itself first. Compressed
/// rows over all patches; non-boundary patches have none.
#[derive(Default)]
struct Neighbours {
    start: Vec<u32>,
    list: Vec<u32>,
    /// 1 / the summed area of each patch's neighbourhood.
    inv_area: Vec<f32>,
}

impl Neighbours {
    fn of_boundary(world: &World) -> Neighbours {
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
        let mut start = Vec::with_capacity(p.len() + 1);
        let mut list = Vec::new();
        start.push(0);
        let mut near = Vec::new();
        for i in 0..p.len() {
            if boundary(i) {
                near.clear();
                for &c in &p.corner_vertex[i] {
                    near.extend(at_vertex(c).iter().filter(|&&k| k as usize != i));
                }
                near.sort_unstable();
                near.dedup();
                list.push(i as u32);
                list.extend_from_slice(&near);
            }
            start.push(list.len() as u32);
        }
        let mut n = Neighbours {
            start,
            list,
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

    fn of(&self, i: usize) -> &[u32] {
        match (self.start.get(i), self.start.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.list[a as usize..b as usize],
            _ => &[],
        }
    }
}

/// Sum irradiance pieces per patch: one entry per patch, in order of first appearance.
/// `scratch` (one value per patch, all zero) is left all zero.
fn sum_by_patch(
    scratch: &mut [Vec3],
    pieces: impl IntoIterator<Item = (u32, Vec3)>,
) -> Vec<(u32, Vec3)> {
    let mut touched: Vec<u32> = Vec::new();
    for (j, e) in pieces {
        let s = &mut scratch[j as usize];
        if *s == Vec3::ZERO {
            touched.push(j);
        }
        *s += e;
    }
    // A patch whose pieces cancelled to exactly zero would be listed twice: drop repeats.
    touched
        .into_iter()
        .filter_map(|j| {
            let e = std::mem::take(&mut scratch[j as usize]);
            (e != Vec3::ZERO).then_some((j, e))
        })
        .collect()
}

/// The Step 3 emitters of object `o`: one at the box centre with every patch (the paper), or
/// one per dominant normal axis (±x, ±y, ±z of the rest frame) at the area-weighted
/// centroid of its patches.
fn emitter_groups(
    p: &crate::Patches,
    o: usize,
    box_centre: Vec3,
    per_face: bool,
) -> Vec<(Vec3, Vec<u32>)> {
    let range = p.range(o);
    if !per_face {
        return vec![(box_centre, (0..range.len() as u32).collect())];
    }
    let mut groups: Vec<(Vec3, f32, Vec<u32>)> = vec![(Vec3::ZERO, 0.0, Vec::new()); 6];
    for (k, i) in range.enumerate() {
        let n = p.normal_local[i];
        let axis = n.abs().max_position();
        let g = 2 * axis + usize::from(n[axis] < 0.0);
        groups[g].0 += p.centre_local[i] * p.area[i];
        groups[g].1 += p.area[i];
        groups[g].2.push(k as u32);
    }
    groups
        .into_iter()
        .filter(|g| g.1 > 0.0)
        .map(|(sum, area, members)| (sum / area, members))
        .collect()
}

/// Transfer vectors with self-visibility of object `o`'s patches, in the object frame:
/// `T_i = (pi / M) sum_j V_self(w_j) Y(w_j)` over `M` cosine-distributed directions (the
/// pdf `cos / pi` turns the cosine-weighted integral into this mean). Rays are cast in the
/// world at rest with every other object transparent, so only the object itself occludes.
fn self_transfer(
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
        let shift = (
            crate::sampling::unit(crate::sampling::hash(i as u32 ^ 0x5eed)),
            0.25,
        );
        for j in 0..rays {
            let (u, v) = crate::sampling::hammersley(j as u32, rays as u32, shift);
            let local = crate::sampling::square_to_cosine_hemisphere(u, v, p.normal_local[i]);
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

/// World bounding box of object `o` (its rest-frame mesh box, transformed).
fn world_box(world: &World, o: usize) -> (Vec3, Vec3) {
    let m = world.patches.world_from_local[o];
    let Some((lo, hi)) = world.patches.shapes[o].bounds() else {
        return (Vec3::ZERO, Vec3::ZERO);
    };
    (0..8)
        .map(|c| {
            let s = Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
            m.transform_point3(lo + (hi - lo) * s)
        })
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), q| {
            (a.min(q), b.max(q))
        })
}

/// Bounding sphere of a box.
fn sphere((lo, hi): (Vec3, Vec3)) -> (Vec3, f32) {
    (0.5 * (lo + hi), 0.5 * (hi - lo).length())
}

/// Does the cone from `x` to the sphere `(lc, lr)` (a light) meet the sphere `(bc, br)`?
/// Conservative: the cone is widened linearly from 0 at `x` to `lr` at the light.
fn cone_meets_sphere(x: Vec3, lc: Vec3, lr: f32, bc: Vec3, br: f32) -> bool {
    let axis = lc - x;
    let len2 = axis.length_squared().max(1e-30);
    let s = ((bc - x).dot(axis) / len2).clamp(0.0, 1.0);
    let closest = x + axis * s;
    (bc - closest).length() <= br + lr * s * 1.1 + 1e-6
}

/// Slab test of the ray `o + t d`, `t > 0`, against a box.
fn ray_meets_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let inv = d.recip();
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let near = t0.min(t1).max_element();
    let far = t0.max(t1).min_element();
    far >= near.max(0.0)
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patches::PatchSizing;
    use shrad_scene::{Material, Object, Scene};
    use shrad_vis::Backend;

    /// A closed room (six inward walls) around one interior sphere.
    fn sphere_in_a_room() -> Scene {
        let mut room = shrad_scene::room(&shrad_scene::RoomParams {
            objects: 0,
            patches: 1000,
            big_object_patches: None,
        });
        room.objects.retain(|o| o.role == Some(Role::Boundary));
        let mut ball = Object::new(
            "ball",
            shrad_scene::cornell_box().objects[0].mesh.clone(),
            Material::diffuse(Vec3::splat(0.5)),
        );
        // A sphere mesh from the room generator: take it from a room with 3 objects.
        let with_sphere = shrad_scene::room(&shrad_scene::RoomParams {
            objects: 3,
            patches: 1000,
            big_object_patches: None,
        });
        let sphere = with_sphere
            .objects
            .iter()
            .find(|o| o.name.starts_with("sphere"))
            .unwrap();
        ball.mesh = sphere.mesh.clone();
        ball.world_from_object = Affine3A::from_translation(Vec3::new(4.0, 1.5, 3.0));
        ball.role = Some(Role::Interior);
        room.objects.push(ball);
        room
    }

    #[test]
    fn trilinear_weights_reproduce_a_linear_field() {
        let scene = shrad_scene::cornell_box();
        let world = World::new(scene, PatchSizing::Size(40.0), Backend::Auto).unwrap();
        let d = Dispersive::new(&world, DispersiveOptions::improved());
        let f = |x: Vec3| 0.3 * x.x - 1.7 * x.y + 2.1 * x.z + 5.0;
        for ob in &d.objects {
            for (k, i) in world.patches.range(ob.object).enumerate() {
                let x = world.patches.centre_local[i];
                let interpolated: f32 = (0..8)
                    .map(|c| ob.weights[k][c] * f(ob.corner_local(c)))
                    .sum();
                assert!(
                    (interpolated - f(x)).abs() < 1e-3 * (1.0 + f(x).abs()),
                    "{interpolated} vs {}",
                    f(x)
                );
            }
        }
    }

    /// Step 3 sends the object's reflected flux to a closed boundary, all of it.
    #[test]
    fn object_sends_its_reflected_flux_to_a_closed_boundary() {
        for to_boundary in [ToBoundary::Splat, ToBoundary::Gather] {
            let world =
                World::new(sphere_in_a_room(), PatchSizing::Size(0.05), Backend::Auto).unwrap();
            let options = DispersiveOptions {
                to_boundary,
                emitter_res: 128,
                ..DispersiveOptions::improved()
            };
            let mut d = Dispersive::new(&world, options);
            let p = &world.patches;
            let ball = world.scene.objects.len() - 1;
            // Give the ball a known, non-uniform reflected radiosity.
            let mut reflected_flux = 0.0f64;
            for i in p.range(ball) {
                let b = Vec3::new(1.0, 0.5, 0.25) * (1.5 + p.normal[i].y);
                d.radiosity[i] = b;
                reflected_flux += (b * p.area[i]).element_sum() as f64;
            }
            d.objects_to_boundary(&world, vec![0]);
            let received: f64 = d
                .boundary_patches
                .iter()
                .map(|&j| (d.indirect[j as usize] * p.area[j as usize]).element_sum() as f64)
                .sum();
            let ratio = received / reflected_flux;
            assert!(
                (ratio - 1.0).abs() < 0.01,
                "{to_boundary:?}: received / sent = {ratio}"
            );
        }
    }

    #[test]
    fn a_static_scene_stops_changing() {
        let world = World::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(3000),
            Backend::Auto,
        )
        .unwrap();
        for options in [DispersiveOptions::improved(), DispersiveOptions::paper()] {
            let mut d = Dispersive::new(
                &world,
                DispersiveOptions {
                    cube_res: 32,
                    ..options
                },
            );
            d.converge(&world, 30);
            let before = d.radiosity.clone();
            d.converge(&world, 1);
            let scale = before.iter().map(|b| b.max_element()).fold(0.0, f32::max);
            let change = before
                .iter()
                .zip(&d.radiosity)
                .map(|(a, b)| (*a - *b).abs().max_element())
                .fold(0.0, f32::max);
            assert!(change <= 1e-4 * scale, "max change {change} of {scale}");
        }
    }

    #[test]
    fn probes_buried_in_the_floor_are_detected_and_repaired() {
        // Both Cornell blocks stand on the floor: with a margin, their 4 lower corner probes
        // lie under it and see its back.
        let world = World::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(3000),
            Backend::Auto,
        )
        .unwrap();
        let options = DispersiveOptions {
            cube_res: 32,
            repair: ProbeRepair::None,
            schedule: Schedule::Full,
            ..DispersiveOptions::improved()
        };
        let mut d = Dispersive::new(&world, options);
        let stats = d.step(&world, &Changes::default());
        assert_eq!(stats.probes_invalid, 8, "{stats:?}");
        let mut d = Dispersive::new(
            &world,
            DispersiveOptions {
                repair: ProbeRepair::MoveInward,
                ..options
            },
        );
        let stats = d.step(&world, &Changes::default());
        assert_eq!((stats.probes_invalid, stats.probes_repaired), (8, 8));
    }

    /// In a closed room at steady state every emitted watt is absorbed somewhere. The
    /// default closes the balance within 5 % (light the emitters themselves absorb is not
    /// counted); the paper, without wall-to-wall light, loses about half (docs/results.md).
    #[test]
    fn energy_balance_closes_in_a_closed_room() {
        let room = shrad_scene::room(&shrad_scene::RoomParams {
            objects: 4,
            patches: 3000,
            big_object_patches: None,
        });
        let world = World::new(room, PatchSizing::Count(3000), Backend::Auto).unwrap();
        let mut d = Dispersive::new(
            &world,
            DispersiveOptions {
                cube_res: 32,
                ..DispersiveOptions::improved()
            },
        );
        let stats = d.converge(&world, 8);
        let e = stats.last().unwrap().energy;
        let gap = (e.absorbed - e.emitted).abs() / e.emitted;
        assert!(gap < 0.05, "{e:?}");
    }

    /// For a convex object the transfer vector is the clamped-cosine lobe and nothing of the
    /// object sees itself.
    #[test]
    fn transfer_of_a_convex_object_is_the_cosine_lobe() {
        let world = World::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(2000),
            Backend::Auto,
        )
        .unwrap();
        let short = world
            .scene
            .objects
            .iter()
            .position(|o| o.name == "short_block")
            .unwrap();
        let (transfer, self_view) = self_transfer(&world, short, 3, 4096);
        let nc = num_coeffs(3);
        for (k, i) in world.patches.range(short).enumerate() {
            let mut lobe = [0f32; 9];
            cosine_lobe_sh(3, world.patches.normal_local[i], &mut lobe);
            for c in 0..nc {
                assert!(
                    (transfer[k * nc + c] - lobe[c]).abs() < 0.02,
                    "coefficient {c}: {} vs {}",
                    transfer[k * nc + c],
                    lobe[c]
                );
            }
            assert!(self_view[k].is_empty());
        }
    }

    /// The default against the reference on the Cornell box (docs/results.md has the full
    /// figures); a regression guard with room for the reference's own noise.
    #[test]
    fn cornell_box_default_is_close_to_the_reference() {
        let world = World::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(4000),
            Backend::Auto,
        )
        .unwrap();
        let mut d = Dispersive::new(&world, DispersiveOptions::improved());
        d.converge(&world, 8);
        let reference = crate::reference::solve(
            &world,
            &crate::reference::ReferenceOptions::standard(),
            &NoProgress,
        )
        .0;
        let e = crate::metrics::relative_error(&world.patches, d.radiosity(), &reference);
        assert!(e.overall < 0.11, "{e:?}");
    }

    /// A reflective, double-sided emitter lying just above the floor (scenes/example.toml's
    /// `glow`): the floor and the emitter's back bounce light between them, which the
    /// dispersive solver must carry like any boundary light (it lost half of it when lights
    /// only emitted: 22 % error).
    #[test]
    fn reflective_light_near_the_floor_bounces_light() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.toml");
        let scene = shrad_scene::load(&path, &Default::default()).unwrap();
        let world = World::new(scene, PatchSizing::Count(4000), Backend::Auto).unwrap();
        let mut d = Dispersive::new(&world, DispersiveOptions::improved());
        d.converge(&world, 8);
        let reference = crate::reference::solve(
            &world,
            &crate::reference::ReferenceOptions::standard(),
            &NoProgress,
        )
        .0;
        let e = crate::metrics::relative_error(&world.patches, d.radiosity(), &reference);
        assert!(e.overall < 0.08, "{e:?}");
    }
}
