//! What a run produces: one [`Record`] per scene x solver, one [`SceneInfo`] per scene, and
//! the [`BenchReport`] that holds them with the machine. `results.json` and `report.json` are
//! these types serialised.

use serde::Serialize;
use shrad::frame::FrameStats;
use shrad::frame::SolverStats;
use shrad::metrics::RelativeError;

use crate::machine::Machine;
use crate::rays::RayRate;
use crate::scenes::Table;
use crate::solvers::SolverKind;

/// Median time of each step over the timed frames (ms).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StepMs {
    /// Step 1, direct light (dispersive; cached after the first frame). Grid: 0.
    pub direct: f64,
    /// Step 2, probe capture + projection + lighting of the selected objects. Grid: capture
    /// and projection of all probes.
    pub objects: f64,
    /// Step 3, objects to boundary (dispersive). Grid: 0.
    pub to_boundary: f64,
    /// Step 4, boundary assembly (dispersive). Grid: interpolation and shading of every
    /// patch.
    pub assemble: f64,
}

impl StepMs {
    /// The four step times of a frame, in the paper's Table 3 columns. The grid has no
    /// Step 1 or 3: its capture is `objects` and its shading `assemble`; the reference has
    /// none of them (0).
    pub fn of(s: &FrameStats) -> StepMs {
        match &s.solver {
            SolverStats::Dispersive(d) => StepMs {
                direct: d.direct_ms,
                objects: d.objects_ms,
                to_boundary: d.to_boundary_ms,
                assemble: d.assemble_ms,
            },
            SolverStats::Grid(g) => StepMs {
                objects: g.capture_ms,
                assemble: g.shade_ms,
                ..StepMs::default()
            },
            SolverStats::Reference(_) => StepMs::default(),
        }
    }
}

/// The frames timed with one object (the largest; Table 3: the grown one; the objects
/// table: the smallest box) moved before each (see [`crate::moving::MOVE_REACH`]).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Moving {
    /// The object moved (its name in the scene).
    pub object: String,
    /// Its patches.
    pub object_patches: usize,
    /// Median `frame_ms`.
    pub frame_ms_median: f64,
    /// The longest frame (ms).
    pub frame_ms_max: f64,
    /// Median of each step.
    pub step_ms: StepMs,
    /// Frames timed.
    pub frames: usize,
    /// grid5's median moving frame / this solver's (same scene, same run).
    pub speedup_vs_grid5: Option<f64>,
    /// grid5-r32's median moving frame / this solver's (same scene, same run): the speed-up
    /// at equal probe resolution.
    pub speedup_vs_grid5_r32: Option<f64>,
    /// The error of the last moving frame against a reference solve of that moved state
    /// (the object where the last frame put it, at its farthest from rest).
    pub error: RelativeError,
    /// Median `rays_cast` of the moving frames.
    pub rays_median: f64,
    /// The time `rays_median` rays take at the scene's measured floor rate
    /// ([`crate::rays::RayRate::floor_rays_per_s`]), ms; NaN when it was not measured.
    pub ray_floor_ms: f64,
    /// `frame_ms_median / ray_floor_ms`: how far the frame is above its rays' floor (NaN
    /// without a floor or without rays).
    pub over_ray_floor: f64,
}

/// Errors after the same frames and after the same time.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Errors {
    /// After [`Record::same_frames`] frames.
    pub same_frames: RelativeError,
    /// After [`Record::same_time_frames`] frames, the first at which the summed frame time
    /// reached [`Record::same_time_budget_ms`].
    pub same_time: RelativeError,
}

/// One point of an error-against-time trace.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TracePoint {
    /// Frames run so far.
    pub frames: usize,
    /// Summed `frame_ms` so far.
    pub ms: f64,
    /// Overall relative error.
    pub error: f64,
}

/// One scene x solver.
#[derive(Clone, Debug, Serialize)]
pub struct Record {
    /// Scene name.
    pub scene: String,
    /// `Scaling` (Tables 1-2), `BigObject` (Table 3) or `Objects` (the object count grows).
    pub table: Table,
    /// Patches of the scene.
    pub patches: usize,
    /// Patches of the grown object (Table 3 scenes) or of the largest interior object
    /// (Tables 1-2).
    pub largest_object_patches: usize,
    /// Interior objects.
    pub interior_objects: usize,
    /// The solver (written as its label: `grid4`, `grid5`, `grid5-r32`, `dispersive`,
    /// `paper`).
    pub solver: SolverKind,
    /// Median of `frame_ms` over the timed frames.
    pub frame_ms_median: f64,
    /// Median `frame_ms` of the timed frames that updated the largest (Table 3: the grown)
    /// object — the paper's Table 3 frame; NaN when no timed frame did (grids update all).
    pub largest_object_frame_ms: f64,
    /// Median of each step over the timed frames.
    pub step_ms: StepMs,
    /// Frames before the timed window.
    pub warmup_frames: usize,
    /// Frames timed.
    pub timed_frames: usize,
    /// Relative errors against the reference.
    pub error: Errors,
    /// Frames for `error.same_frames`.
    pub same_frames: usize,
    /// Budget for `error.same_time` (ms of solver time).
    pub same_time_budget_ms: f64,
    /// Frames the solver ran within that budget.
    pub same_time_frames: usize,
    /// grid5's median frame time / this solver's (same scene, same run).
    pub speedup_vs_grid5: Option<f64>,
    /// grid5-r32's median frame time / this solver's (same scene, same run).
    pub speedup_vs_grid5_r32: Option<f64>,
    /// Time to build the solver (precomputation), ms.
    pub setup_ms: f64,
    /// Process high-water mark (VmHWM) at the end of this solver's run, MiB. When
    /// `peak_is_per_solver`, the mark was reset just before the solver was built, so this is
    /// the peak during this solver's run (the world and the reference, held throughout,
    /// included); else it is the process's peak so far.
    pub peak_mib: f64,
    /// The high-water mark was reset before this solver (Linux /proc/self/clear_refs).
    pub peak_is_per_solver: bool,
    /// `peak_mib` minus the resident set just before the solver was built: the solver's own
    /// peak, transient buffers (cube-map hit buffers) included. NaN when the mark could not
    /// be reset.
    pub solver_peak_mib: f64,
    /// Resident-set growth (VmRSS) from before building the solver to the end of its
    /// warm-up, MiB: the solver's own state (a lower bound when the allocator reuses memory
    /// freed by an earlier solver).
    pub solver_rss_mib: f64,
    /// Resident-set growth while building the world (patches + visibility), MiB.
    pub world_rss_mib: f64,
    /// Result check before timing: "ok" or what failed.
    pub check: String,
    /// Error against summed frame time, from the first frame on (at most ~80 points).
    pub trace: Vec<TracePoint>,
    /// Frames with one object moving every frame (after the static ones; None when the
    /// scene has no interior object or none were asked for).
    pub moving: Option<Moving>,
}

/// Statistics of one scene's reference solve.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    /// Scene name.
    pub scene: String,
    /// Patches.
    pub patches: usize,
    /// Boundary, interior, light patches.
    pub by_role: (usize, usize, usize),
    /// Reference solve time (s).
    pub reference_seconds: f64,
    /// Reference converged.
    pub reference_converged: bool,
    /// World build time (s).
    pub world_seconds: f64,
    /// The visibility backend's measured ray rates in this scene (all zero when not
    /// measured).
    pub ray_rate: RayRate,
    /// Reference solves of moved states (the error while moving): how many, and their
    /// summed time (s).
    pub moved_references: usize,
    /// Their summed time (s).
    pub moved_reference_seconds: f64,
}

/// Everything a run produced.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// The machine.
    pub machine: Machine,
    /// One per scene x solver.
    pub records: Vec<Record>,
    /// One per scene.
    pub scenes: Vec<SceneInfo>,
    /// Reference rays per patch used.
    pub reference_rays: u32,
    /// Total wall time (s).
    pub seconds: f64,
}

impl BenchReport {
    /// The record of `solver` on `scene`.
    pub fn find(&self, scene: &str, solver: SolverKind) -> Option<&Record> {
        self.records
            .iter()
            .find(|r| r.scene == scene && r.solver == solver)
    }

    /// The scenes that belong to `table`, in run order.
    pub fn scenes_of(&self, table: Table) -> Vec<&SceneInfo> {
        self.scenes
            .iter()
            .filter(|i| {
                self.records
                    .iter()
                    .any(|r| r.scene == i.scene && r.table == table)
            })
            .collect()
    }
}
