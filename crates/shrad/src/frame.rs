//! The one frame interface of the three solvers: what a frame takes ([`Changes`]: what moved
//! or changed emission or reflectance since the last frame, which the [`Engine`](crate::engine::Engine)
//! collects itself) and what it gives ([`FrameStats`]: statistics every solver has, plus a
//! [`SolverStats`] part of its own). `render`, `animate`, `bench`, the viewer and Python read
//! the same value whichever solver runs.

pub use crate::energy::{Divergence, EnergyBalance};

/// What changed in the world since the last frame.
#[derive(Clone, Debug, Default)]
pub struct Changes {
    /// Objects whose transform changed.
    pub moved: Vec<usize>,
    /// Objects whose emission or reflectance changed (either changes the light they send).
    pub relit: Vec<usize>,
    /// Punctual lights that moved or changed colour or intensity (the solvers also compare
    /// the light states they traced with the world's, so a light changed by
    /// [`World::set_time`](crate::World::set_time) alone is not missed). Index
    /// `world.lights.len()` stands for the sky.
    pub lights: Vec<usize>,
}

impl Changes {
    /// Did any light change: a light surface's emission or a punctual light?
    pub fn light_changed(&self) -> bool {
        !self.relit.is_empty() || !self.lights.is_empty()
    }
}

/// Statistics of one frame, common to every solver, with the solver's own in
/// [`FrameStats::solver`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct FrameStats {
    /// Frame index (since the solver was made).
    pub frame: u64,
    /// Whole frame (ms).
    pub frame_ms: f64,
    /// Objects updated this frame (the dispersive scheduler's pick; empty for the grid and
    /// the reference, which update every patch).
    pub objects_updated: Vec<usize>,
    /// Frames since the stalest interior object was updated (0 for solvers that update
    /// everything every frame).
    pub stalest: u64,
    /// Flux balance.
    pub energy: EnergyBalance,
    /// Set when the state broke the energy bound or held non-finite values: what diverged
    /// and what was damped or reset (the published state is the repaired one).
    pub diverged: Option<Divergence>,
    /// Rays the frame cast (probes, shadow rays, form factors: every visibility query).
    pub rays_cast: u64,
    /// What only this solver reports.
    pub solver: SolverStats,
}

impl FrameStats {
    /// Empty statistics of frame `frame` with `solver`'s own part.
    pub fn new(frame: u64, solver: SolverStats) -> FrameStats {
        FrameStats {
            frame,
            frame_ms: 0.0,
            objects_updated: Vec::new(),
            stalest: 0,
            energy: EnergyBalance::default(),
            diverged: None,
            rays_cast: 0,
            solver,
        }
    }

    /// The dispersive solver's part, if it ran the frame.
    pub fn dispersive(&self) -> Option<&DispersiveStats> {
        match &self.solver {
            SolverStats::Dispersive(d) => Some(d),
            _ => None,
        }
    }

    /// The grid's part, if it ran the frame.
    pub fn grid(&self) -> Option<&GridStats> {
        match &self.solver {
            SolverStats::Grid(g) => Some(g),
            _ => None,
        }
    }

    /// The reference's part, if it ran the frame.
    pub fn reference(&self) -> Option<&ReferenceStats> {
        match &self.solver {
            SolverStats::Reference(r) => Some(r),
            _ => None,
        }
    }
}

/// The part of [`FrameStats`] only one solver has.
#[derive(Clone, Debug, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SolverStats {
    /// The dispersive solver's four steps (the paper's Table 3 columns).
    Dispersive(DispersiveStats),
    /// The grid baseline's two phases.
    Grid(GridStats),
    /// The reference solve (it solves to convergence every frame).
    Reference(ReferenceStats),
}

/// A dispersive frame, step by step (paper 2.2).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct DispersiveStats {
    /// Step 1, direct light on the boundary, and the wall rows a mover passed, with what
    /// runs beside them (the first object's Step 2, Step 4's gather) (ms).
    pub direct_ms: f64,
    /// Step 2, lighting the selected objects from their probes (ms). The first object is
    /// lit beside Step 1, so this and `direct_ms` overlap: they may add up to more than the
    /// frame.
    pub objects_ms: f64,
    /// Step 3, the selected objects to the boundary (ms).
    pub to_boundary_ms: f64,
    /// Step 4, assembling the boundary's radiosity, the wall exchange (ms).
    pub assemble_ms: f64,
    /// Probes captured (8 per updated object, more when a repair moves one).
    pub probes_captured: usize,
    /// Texels of cached probes traced again because a mover's box met their rays (a probe
    /// captured whole counts in `probes_captured` instead).
    pub probe_texels_retraced: usize,
    /// Probes found invalid among those captured this frame.
    pub probes_invalid: usize,
    /// Of those, repaired by moving.
    pub probes_repaired: usize,
    /// Interior objects asleep after the frame (their light stopped changing:
    /// `sleep_tolerance`).
    pub objects_asleep: usize,
    /// Everything slept: the frame traced nothing and swept nothing.
    pub asleep: bool,
    /// Wall-exchange rows not built yet (a large scene builds them over its first frames;
    /// until then the walls exchange only the light of the rows that are ready).
    pub wall_rows_pending: usize,
}

/// What the reference solve did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ReferenceStats {
    /// Jacobi iterations run.
    pub iterations: usize,
    /// Final `max |dB| / max B`.
    pub residual: f32,
    /// Did it reach the tolerance?
    pub converged: bool,
    /// Seconds spent on direct light.
    pub direct_seconds: f64,
    /// Seconds spent estimating form factors.
    pub form_factor_seconds: f64,
    /// Seconds spent iterating.
    pub solve_seconds: f64,
    /// Non-zero form factors stored.
    pub form_factor_entries: usize,
    /// Bytes of the form-factor matrix.
    pub form_factor_bytes: usize,
    /// Flux balance of the solution, over every patch (the emitters' absorption included).
    pub energy: crate::energy::EnergyBalance,
    /// Non-finite values reset to 0 (always 0 unless an input was broken).
    pub non_finite: usize,
}

/// A grid frame: every probe captured, every patch shaded.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct GridStats {
    /// Capturing and projecting every probe (ms).
    pub capture_ms: f64,
    /// Interpolating to every patch, shading and the energy meter (ms).
    pub shade_ms: f64,
    /// Probes captured (G^3).
    pub probes: usize,
    /// Probes that see mostly back faces (buried in an object; the paper's Figure 1).
    pub probes_invalid: usize,
}
