//! The table of keys of each solver: name, doc, range, and whether a change rebuilds.

use super::{KeySpec, Range};

pub(super) const fn int(
    name: &'static str,
    min: u64,
    max: u64,
    rebuilds: bool,
    doc: &'static str,
) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Int { min, max },
        rebuilds,
    }
}

pub(super) const fn float(name: &'static str, min: f64, max: f64, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Float {
            min,
            max,
            min_open: false,
        },
        rebuilds: true,
    }
}

pub(super) const fn flag(name: &'static str, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Bool,
        rebuilds: true,
    }
}

pub(super) const fn choice(
    name: &'static str,
    names: &'static [&'static str],
    rebuilds: bool,
    doc: &'static str,
) -> KeySpec {
    KeySpec {
        name,
        doc,
        range: Range::Choice(names),
        rebuilds,
    }
}

/// Largest cube-map face resolution (2048^2 x 6 texels a probe).
pub(super) const MAX_RES: u64 = 2048;
/// Most SH bands `shrad-sh` evaluates.
pub(super) const MAX_BANDS: u64 = 8;
/// Most rays per patch of any per-patch ray count.
pub(super) const MAX_RAYS: u64 = 65_536;

/// The schedules, as the `schedule` key names them.
pub(super) const SCHEDULES: &[&str] = &["round_robin", "priority", "budget", "full"];
/// The probe repairs, as the `repair` key names them.
pub(super) const REPAIRS: &[&str] = &["none", "drop", "move_inward", "move_out"];
/// The Step 3 methods, as the `to_boundary` key names them.
pub(super) const TO_BOUNDARY: &[&str] = &["splat", "gather", "auto"];

/// A schedule parameter missing from the schedule switched from takes this.
pub(super) const DEFAULT_PER_FRAME: usize = 1;
/// See [`DEFAULT_PER_FRAME`].
pub(super) const DEFAULT_MAX_STALENESS: usize = 16;
/// See [`DEFAULT_PER_FRAME`].
pub(super) const DEFAULT_BUDGET_MS: f32 = 20.0;

/// The dispersive solver's keys (fields of [`crate::dispersive::DispersiveOptions`]; `schedule`, `per_frame`,
/// `max_staleness` and `budget_ms` flatten its [`crate::dispersive::Schedule`]).
pub const DISPERSIVE_KEYS: &[KeySpec] = &[
    int("bands", 1, MAX_BANDS, true, "SH bands (paper: 4 = 16 coefficients)"),
    int(
        "cube_res",
        1,
        MAX_RES,
        true,
        "cube-map face resolution of the probes (paper: 128; 32 measures as well once direct light on interior objects is computed apart)",
    ),
    int(
        "emitter_res",
        1,
        MAX_RES,
        true,
        "cube-map face resolution of the Step 3 splat from each object (paper: the probes' 128)",
    ),
    float(
        "probe_margin",
        0.0,
        1.0,
        "probe box margin as a fraction of the box diagonal (paper: 0, the exact box)",
    ),
    choice(
        "schedule",
        SCHEDULES,
        false,
        "which objects a frame updates: in order, by priority (motion, staleness), as many as fit in budget_ms, or all",
    ),
    int(
        "per_frame",
        1,
        1_000_000,
        false,
        "objects updated per frame, K (schedule round_robin and priority)",
    ),
    int(
        "max_staleness",
        1,
        1_000_000,
        false,
        "no object waits more frames than this (schedule priority and budget)",
    ),
    KeySpec {
        name: "budget_ms",
        doc: "per-frame deadline for the whole frame (all four steps); an object or Step 1 that does not fit waits a frame, and no object starves (schedule budget; 20 when that schedule is chosen without it)",
        range: Range::Float {
            min: 0.0,
            max: 60_000.0,
            min_open: true,
        },
        rebuilds: false,
    },
    float(
        "invalid_back_fraction",
        0.0,
        1.0,
        "back-face fraction above which a probe is invalid (DDGI: 0.25)",
    ),
    choice(
        "repair",
        REPAIRS,
        true,
        "invalid probes: kept (the paper), dropped with the weights renormalised, moved towards the box centre along the diagonal, or first along the box axis that leads out of the surface they are buried in (move_out: beside the object, not above the dark floor under it)",
    ),
    flag(
        "wall_exchange",
        "carry boundary-to-boundary light (precomputed sparse form factors, one Jacobi sweep a frame)",
    ),
    int(
        "wall_rays",
        1,
        MAX_RAYS,
        true,
        "form-factor rays per boundary patch for the wall exchange",
    ),
    flag(
        "see_through_self",
        "capture probes with the object's own geometry transparent (else its texels are black)",
    ),
    flag(
        "direct_on_interior",
        "direct light on interior patches computed like the boundary's; probes then carry reflected light only",
    ),
    int(
        "direct_samples",
        1,
        MAX_RAYS,
        true,
        "shadow rays per (patch, emitter) for direct light",
    ),
    choice(
        "to_boundary",
        TO_BOUNDARY,
        true,
        "Step 3: the paper's cube-map splat, a per-patch gather with a shadow ray, or gather on small boundaries and splat on large ones",
    ),
    int(
        "contact_rays",
        0,
        4096,
        true,
        "rays per interior patch detecting faces in contact with other surfaces (0: off, the paper)",
    ),
    flag(
        "emitter_per_face",
        "Step 3 with one SH emitter per face direction of the object instead of one at its centre",
    ),
    int(
        "emitter_split",
        1,
        8,
        true,
        "with emitter_per_face and the gather, each face direction's emitter also split into n x n across the face for the receivers near it, so a large face lights the floor at its foot from its lower part (1: one a face; a splat never splits)",
    ),
    int(
        "self_shadow_rays",
        0,
        MAX_RAYS,
        true,
        "rays per interior patch for transfer vectors with self-visibility, so concave objects shadow and light themselves (0: the plain cosine lobe)",
    ),
    flag(
        "splat_smoothing",
        "spread each boundary patch's splatted flux over its edge neighbours, against the texel pattern",
    ),
    flag(
        "wall_smoothing",
        "average each boundary patch's wall-exchange irradiance over its edge neighbours within a factor of 2 of it (fading out by 4: a real step stays), against the rays' noise (blotches under bright small patches)",
    ),
    float(
        "sleep_tolerance",
        0.0,
        0.1,
        "an object sleeps once an update changes its light by less than this fraction, and the walls once a sweep does; a change of light or a mover nearby wakes them (0: never sleep, the paper)",
    ),
    flag(
        "coarse_while_moving",
        "an object that moved since the last frame is updated from half-resolution cube maps and a quarter of the direct light's samples (light surfaces, lamps and the sky), and at full resolution once it stops",
    ),
    flag(
        "one_emitter_while_moving",
        "while an object moves (with coarse_while_moving), Step 3 sends its light from one SH emitter at its box centre, as the paper does, instead of one per face direction",
    ),
    float(
        "resend_tolerance",
        0.0,
        0.5,
        "while another object moves, a still object sends the boundary only the light paths the mover crossed, unless its emitted light changed by more than this fraction since it was sent; at rest everything is sent again (0: always everything, the paper)",
    ),
    int(
        "near_rays",
        0,
        MAX_RAYS,
        true,
        "rays per interior patch for its near field: light from surfaces within near_reach is gathered from their radiosity, not read from the probes (the floor beside a box, the shadow under a sphere); stands in for contact openness (0: off, the paper)",
    ),
    float(
        "near_reach",
        0.0,
        1.0,
        "the near field's reach, a fraction of the object's probe box diagonal",
    ),
    flag(
        "probe_visibility",
        "leave out of a patch's interpolation the probes another object hides from it (a crate sunk into the floor is not lit below it from the probes above; off: all 8, the paper)",
    ),
    flag(
        "see_through_near",
        "an object's probes see through the interior objects within its near reach, which its near field takes at any distance instead (no parallax of a ball beside a block; off: the probes see them, the paper)",
    ),
];

/// The grid baseline's keys (fields of [`crate::grid::GridOptions`]).
pub const GRID_KEYS: &[KeySpec] = &[
    int(
        "per_axis",
        1,
        64,
        true,
        "probes per axis, G (paper: 4 and 5)",
    ),
    int(
        "cube_res",
        1,
        MAX_RES,
        true,
        "cube-map face resolution of the probes (paper: 128)",
    ),
    int("bands", 1, MAX_BANDS, true, "SH bands (paper: 4)"),
];

/// The reference solver's keys (fields of [`crate::reference::ReferenceOptions`]). It keeps nothing between
/// frames, so none needs a rebuild.
pub const REFERENCE_KEYS: &[KeySpec] = &[
    int(
        "rays_per_patch",
        1,
        MAX_RAYS,
        false,
        "form-factor rays per patch (256: about 3 % noise per patch on the indirect term)",
    ),
    int(
        "direct_samples",
        1,
        MAX_RAYS,
        false,
        "shadow rays per (patch, emitter) for the visible fraction of direct light",
    ),
    KeySpec {
        name: "tolerance",
        doc: "stop iterating when max |dB| <= tolerance * max B",
        range: Range::Float {
            min: 0.0,
            max: 1.0,
            min_open: true,
        },
        rebuilds: false,
    },
    int(
        "max_iterations",
        1,
        1_000_000,
        false,
        "give up after this many Jacobi iterations (reported as not converged)",
    ),
];
