//! The [`Batch`] the scheduler hands from the selection of paper 2.3.3 Step 1 to Steps 2
//! and 3. What a frame takes and gives (paper 2.2, the frame of four steps: `Changes` in,
//! `FrameStats` out) is shared by every solver and lives in `crate::frame`.

/// The objects a frame updates. `#[must_use]`: a batch that is not applied is a bug.
#[must_use = "a scheduled batch must be lit (Step 2) and sent to the boundary (Step 3)"]
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Batch(pub Vec<usize>);
