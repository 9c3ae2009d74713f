//! The benchmark harness of shrad: the paper's Tables 1-3 reproduced in one run, apart from
//! the core library (it reads `/proc`, draws plots and writes files; the core does none of
//! that).
//!
//! For every scene (the built-in `room` at the paper's patch counts, [`scenes`]) and every
//! solver ([`SolverKind`]: grid G=4, grid G=5, grid G=5 at the default's probe resolution,
//! the dispersive method with shrad's defaults and with the paper's preset), in one process:
//!
//! - a fresh [`shrad::engine::Engine`] over the scene's world runs frames on the static
//!   scene from its initial state (radiosity = emission);
//! - after its warm-up frames the radiosity is checked (finite, non-negative, not all zero,
//!   relative error against the reference below [`BenchOptions::error_bound`]) *before* any
//!   frame is timed;
//! - the timed window gives the median frame time and the median of each step;
//! - the error against the reference (area-weighted relative L2, [`shrad::metrics`]) is
//!   taken after the same number of frames for every solver ([`BenchOptions::same_frames`])
//!   and after the same solver time: the sum of `frame_ms` of grid5's first
//!   [`BenchOptions::same_time_grid5_frames`] frames in the same scene (each solver runs
//!   until its own summed `frame_ms` reaches it);
//! - then one object moves before every frame (the largest; Table 3: the grown one; the
//!   objects scenes: the smallest box) and those frames are timed too, with the error of the
//!   last of them against a reference solve of that moved state, and their rays against the
//!   scene's ray floor (the backend's rate measured once per scene, [`rays`]);
//! - the objects scenes (40k patches, 8 / 32 / 128 interior objects, [`object_scenes`]) run
//!   the dispersive default only: does a moving frame grow with the number of objects?
//! - memory: the process's resident-set growth while the solver was built and warmed up, and
//!   the process's high-water mark ([`machine`]);
//! - the first line of the log is the machine the run is on.
//!
//! [`write_outputs`] writes `results.json`, `report.json`, `results.md` and the plots.
//! The command is `shrad bench` (crates/shrad-cli); the protocol and the figures are in
//! `docs/results-bench.md`.

pub mod machine;
mod markdown;
pub mod moving;
mod output;
pub mod plots;
pub mod rays;
mod report;
mod run;
mod scenes;
mod solvers;

pub use machine::Machine;
pub use markdown::{markdown, summary};
pub use moving::{moved_transform, moving_frames, MOVE_PERIOD_FRAMES, MOVE_REACH};
pub use output::write_outputs;
pub use rays::{best_ray_rate, measure_ray_rate, RayRate};
pub use report::{BenchReport, Errors, Moving, Record, SceneInfo, StepMs, TracePoint};
pub use run::{check_radiosity, median, run, BenchOptions};
pub use scenes::{
    build_world, object_scenes, scenes, SceneSpec, Table, OBJECTS_PATCHES, OBJECT_COUNTS,
};
pub use solvers::SolverKind;
