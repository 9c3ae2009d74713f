//! The dispersive solver's settings: [`DispersiveOptions`] with its two presets, the paper as
//! written ([`DispersiveOptions::paper`], Wang, Liu & Wu 2007, sections 2.3.1–2.3.5) and
//! shrad's default ([`DispersiveOptions::improved`]), and the enums that pick a variant of a
//! step: [`Schedule`] (paper 2.3.3 Step 1, object selection), [`ProbeRepair`] (probes of
//! paper 2.3.3 Step 2) and [`ToBoundary`] (paper 2.3.4). Every departure from the paper is
//! one field, measured in `docs/results.md`.

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
    /// A deadline: the whole frame (all four steps) within `ms` milliseconds. Objects are
    /// taken by priority while their measured cost fits what is left after Steps 1 and 4's
    /// expected cost (at least one, so the scene always progresses); the wall rows' checks
    /// and re-traces and Step 4's window shrink to what is left; what does not fit waits for
    /// the next frames (the staleness bound still holds).
    Budget {
        /// Per-frame time budget for the whole frame (ms).
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
    /// Move it towards the centre along the one box axis that points most nearly at the
    /// closest back face it sees (up, out of the floor it is buried in, staying beside its
    /// object), and if that finds no valid place, along the diagonal as `MoveInward`.
    MoveOut,
}

impl ProbeRepair {
    /// Whether invalid probes are moved (`MoveInward`, `MoveOut`).
    pub fn moves(self) -> bool {
        matches!(self, ProbeRepair::MoveInward | ProbeRepair::MoveOut)
    }
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
    /// Form-factor rays per boundary patch for the wall exchange (halved on boundaries too
    /// large for them all: `wall_rows::wall_rays_for`).
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
    /// With `emitter_per_face` and the gather, each face direction's emitter also split into
    /// `n x n` emitters across the face (cells of its two in-plane axes, each at its patches'
    /// centroid) that light the receivers within twice the face's diagonal, the whole face
    /// lighting the rest: a large face close to a wall lights the floor at its foot from its
    /// lower half, not from its middle. 1: one emitter a face direction. A splat never splits
    /// (`setup::emitter_groups`).
    pub emitter_split: u32,
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
    /// Average each boundary patch's wall-exchange irradiance (Step 4) over the patch and
    /// its edge neighbours (area weighted, never across a crease): the rows' `wall_rays`
    /// Monte-Carlo rays each hit one patch, so a small, very bright boundary patch (a ceiling
    /// lit from 1 cm by a double-sided lamp) is hit by one ray of one row and not by its
    /// neighbours' rows: a single-patch blotch, and a mottled wall wherever the reflected
    /// light is uneven (issue 22: the animated room's three blotches; docs/results.md).
    pub wall_smoothing: bool,
    /// Sleep and wake (beyond the paper, which updates some object every frame forever): an
    /// object whose update changed its patches' radiosity by less than this fraction (area
    /// weighted, over the object) sleeps, and is skipped by the scheduler until a light
    /// changes, a mover comes near it, or the boundary's light drifts by more than this
    /// fraction since it fell asleep; the walls (Step 4's exchange) sleep likewise once
    /// their sweeps change the boundary by less than it, and a frame in which everything
    /// sleeps costs no tracing and no sweep. 0: never sleep (the paper).
    pub sleep_tolerance: f32,
    /// An object that moved since the last frame is updated from coarser cube maps
    /// (`cube_res / 2` probes, a quarter of the rays; `3 emitter_res / 8` splat, 9/64 of them:
    /// at the 77k room 24^2 against 32^2 cost 0.04 points of error while moving and 1.5 ms),
    /// its own patches' direct light from a quarter of `direct_samples` (the light surfaces',
    /// a quarter of the patches each frame in turn; the lamps' and the sky's, in the frames
    /// that read it), and again at full resolution as soon as it stops (beyond the
    /// paper: the light of a
    /// moving object is wrong by its motion anyway, so the frame spends its rays on
    /// following it; the light settles at full resolution once it rests).
    pub coarse_while_moving: bool,
    /// While an object moves (with `coarse_while_moving`), Step 3 sends its light from one
    /// SH emitter at its box centre, as the paper does, instead of one per face direction
    /// (`emitter_per_face`): a sixth of the splat's rays for light that is wrong by the
    /// motion anyway; per face again once it rests.
    pub one_emitter_while_moving: bool,
    /// While another object moves, a still object's update sends the boundary only the
    /// light paths the mover crossed (its splat's texels, traced again), unless the light
    /// it emits changed by more than this fraction since it was sent; at rest, and after a
    /// light changed, it sends everything again, so a settled scene converges to the same
    /// light (beyond the paper: in the 1M-patch room a still neighbour's full splat reaches
    /// 355k boundary patches, the texels a mover crosses a few hundred). 0: always send
    /// everything.
    pub resend_tolerance: f32,
    /// Rays per interior patch for its near field (`near_field.rs`; 0: off, the paper): in
    /// the directions where a ray meets something within `near_reach`, the patch gathers
    /// that surface's radiosity instead of the probes' radiance (the floor beside a box,
    /// the shadow under a sphere, which the corner probes see in the wrong place), less the
    /// object's own Step 3 light on it (else the two loop). Stands in for contact openness
    /// when on. Issue 22: interior error 77k room 5.2 -> 2.5 %, Cornell 3.7 -> 2.8 %
    /// (docs/results.md §14).
    pub near_rays: u32,
    /// The near field's reach as a fraction of the object's probe box diagonal.
    pub near_reach: f32,
    /// Leave out of a patch's interpolation the probes another object hides from it (a
    /// shadow ray per patch and probe, measured once the object rests and again where a
    /// mover passed; `probe_visibility.rs`): a crate sunk into the floor is not lit below
    /// it from the probes above (beyond the paper, whose interpolation reads all 8).
    pub probe_visibility: bool,
    /// An object's probes see through the interior objects within its near reach, and its
    /// near field's rays take those objects at any distance (`near_field.rs`,
    /// `Dispersive::near_objects`): near objects come from the near field alone, not also,
    /// shifted by parallax, from the probes at the box's corners (the worked example's
    /// interior error 2.63 -> 1.77 %, docs/results.md §14). Off by default: the 77k moving
    /// frame cast 25 % more rays with it (its near fields' longer rays go stale more often)
    /// and took 0.6 ms more.
    pub see_through_near: bool,
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
            emitter_split: 1,
            self_shadow_rays: 0,
            splat_smoothing: false,
            wall_smoothing: false,
            sleep_tolerance: 0.0,
            coarse_while_moving: false,
            one_emitter_while_moving: false,
            resend_tolerance: 0.0,
            near_rays: 0,
            near_reach: 0.25,
            probe_visibility: false,
            see_through_near: false,
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
            repair: ProbeRepair::MoveOut,
            wall_exchange: true,
            see_through_self: true,
            direct_on_interior: true,
            to_boundary: ToBoundary::Auto,
            contact_rays: 8,
            emitter_per_face: true,
            emitter_split: 2,
            self_shadow_rays: 64,
            splat_smoothing: true,
            wall_smoothing: true,
            sleep_tolerance: 1e-4,
            coarse_while_moving: true,
            one_emitter_while_moving: true,
            resend_tolerance: 0.02,
            near_rays: 64,
            near_reach: 0.35,
            probe_visibility: true,
            ..Self::paper()
        }
    }
}

impl Default for DispersiveOptions {
    fn default() -> Self {
        Self::improved()
    }
}
