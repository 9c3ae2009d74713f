//! What a frame takes and gives (paper 2.2, the frame of four steps): [`Changes`] in,
//! [`FrameStats`] out, and the [`Batch`] the scheduler hands from the selection of paper
//! 2.3.3 Step 1 to Steps 2 and 3. The flux balance types come from `crate::energy`.

/// The objects a frame updates. `#[must_use]`: a batch that is not applied is a bug.
#[must_use = "a scheduled batch must be lit (Step 2) and sent to the boundary (Step 3)"]
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Batch(pub Vec<usize>);

/// What changed in the world since the last frame (from [`World::set_time`](crate::World::set_time)).
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
