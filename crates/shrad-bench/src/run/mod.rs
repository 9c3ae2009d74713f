//! Running the protocol: for each scene one world and one reference solve, then each solver
//! in turn on an [`Engine`](shrad::engine::Engine) over that world, checked before it is timed.

use std::time::Instant;

use glam::Vec3;
use shrad::frame::FrameStats;
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::Role;
use shrad::vis::Backend;
use shrad::{Error, NoProgress, Progress, World};

use crate::machine::{memory_mib, Machine};
use crate::moving::MovedReferences;
use crate::rays::{best_ray_rate, RayRate, RAY_RATE_BATCH, RAY_RATE_RAYS, RAY_RATE_REPEATS};
use crate::report::{BenchReport, Record, SceneInfo, StepMs};
use crate::scenes::{build_world, scenes, SceneSpec, Table};
use crate::solvers::SolverKind;

mod solver;
use solver::run_solver;

/// Settings of a benchmark run.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Scenes to run.
    pub scenes: Vec<SceneSpec>,
    /// Solvers to run (grid5 should be first: it sets the same-time budget).
    pub solvers: Vec<SolverKind>,
    /// Visibility backend.
    pub backend: Backend,
    /// Reference solver settings (fewer rays than the standard preset, to fit the time).
    pub reference: ReferenceOptions,
    /// Grid: warm-up frames before the timed window.
    pub grid_warmup: usize,
    /// Grid: timed frames.
    pub grid_timed: usize,
    /// Dispersive: warm-up passes (a pass updates every interior object once).
    pub dispersive_warmup_passes: usize,
    /// Dispersive: timed passes.
    pub dispersive_timed_passes: usize,
    /// Frames after which every solver's error is taken ("same frames"); 0: two passes of
    /// the dispersive scheduler (2 x interior objects).
    pub same_frames: usize,
    /// The same-time budget is the solver time of this many grid5 frames.
    pub same_time_grid5_frames: usize,
    /// No solver runs more frames than this.
    pub max_frames: usize,
    /// Sanity bound on the relative error after warm-up (fraction).
    pub error_bound: f64,
    /// Grid: frames timed with one object moving every frame.
    pub grid_moving: usize,
    /// Dispersive: passes timed with one object moving every frame. Six (52 frames in the
    /// 8-object rooms): about 3 frames in 10 update the mover (twice the cost of the others),
    /// so the median of two passes' 20 frames fell on either kind and moved by a fifth from
    /// run to run (the 77k room: 2.3-3.1 ms, one build, one hour; 2.4-2.5 with six).
    pub dispersive_moving_passes: usize,
    /// The objects scenes ([`Table::Objects`]): frames timed with the smallest box moving
    /// (a fixed count, not passes: a pass of 128 objects would be 128 moving frames; as many
    /// in `--quick` as in the full run, for the same reason as above).
    pub objects_moving_frames: usize,
    /// Rays of each kind cast once per scene to measure the backend's rate (the ray floor,
    /// [`crate::rays`]); 0: not measured.
    pub ray_rate_rays: usize,
}

impl BenchOptions {
    /// The default protocol over [`scenes`]`(quick)`.
    pub fn new(quick: bool) -> Self {
        BenchOptions {
            scenes: scenes(quick),
            solvers: SolverKind::ALL.to_vec(),
            backend: Backend::Auto,
            reference: ReferenceOptions {
                rays_per_patch: 128,
                direct_samples: 32,
                ..ReferenceOptions::standard()
            },
            grid_warmup: 2,
            grid_timed: 5,
            dispersive_warmup_passes: 1,
            dispersive_timed_passes: 2,
            same_frames: 0,
            same_time_grid5_frames: 5,
            max_frames: 4000,
            error_bound: 1.0,
            grid_moving: 3,
            dispersive_moving_passes: 6,
            objects_moving_frames: 36,
            ray_rate_rays: RAY_RATE_RAYS,
        }
    }

    /// The solvers run on `spec`: all of [`BenchOptions::solvers`], or on the objects scenes
    /// only the dispersive default.
    pub fn solvers_for(&self, spec: &SceneSpec) -> Vec<SolverKind> {
        self.solvers
            .iter()
            .copied()
            .filter(|&k| spec.table != Table::Objects || k == SolverKind::Dispersive)
            .collect()
    }

    /// Keep only `solvers` (any order, repeats ignored), run in [`SolverKind::ALL`]'s order
    /// so that grid5, which sets the others' same-time budget, comes first.
    pub fn set_solvers(&mut self, solvers: &[SolverKind]) {
        self.solvers = SolverKind::ALL
            .into_iter()
            .filter(|k| solvers.contains(k))
            .collect();
    }
}

/// Median (0 for an empty slice).
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Is this radiosity usable? `Err` says why not.
pub fn check_radiosity(world: &World, b: &[Vec3]) -> Result<(), String> {
    if b.len() != world.patches.len() {
        return Err(format!(
            "{} values for {} patches",
            b.len(),
            world.patches.len()
        ));
    }
    if let Some(i) = b.iter().position(|v| !v.is_finite()) {
        return Err(format!("patch {i} is not finite: {}", b[i]));
    }
    if let Some(i) = b.iter().position(|v| v.min_element() < 0.0) {
        return Err(format!("patch {i} is negative: {}", b[i]));
    }
    // Something besides the lights must be lit.
    let lit = (0..b.len())
        .filter(|&i| world.patches.role(i) != Role::Light)
        .any(|i| b[i].max_element() > 0.0);
    if !lit {
        return Err("every non-light patch is black".into());
    }
    Ok(())
}

/// What one solver's run keeps of the scene around it.
struct SceneRun<'a> {
    spec: &'a SceneSpec,
    reference: &'a [Vec3],
    world_rss_mib: f64,
    /// The backend's ray rates in this scene (the ray floor).
    ray_rate: RayRate,
    /// The reference solves of moved states (the error while moving).
    moved: MovedReferences,
}

impl<'a> SceneRun<'a> {
    fn new(spec: &'a SceneSpec, reference: &'a [Vec3], world_rss_mib: f64) -> Self {
        SceneRun {
            spec,
            reference,
            world_rss_mib,
            ray_rate: RayRate::default(),
            moved: MovedReferences::default(),
        }
    }
}

/// The median of each step over `stats`, taken separately.
pub(crate) fn step_medians(stats: &[FrameStats]) -> StepMs {
    let steps: Vec<StepMs> = stats.iter().map(StepMs::of).collect();
    let step = |f: fn(&StepMs) -> f64| median(&steps.iter().map(f).collect::<Vec<_>>());
    StepMs {
        direct: step(|s| s.direct),
        objects: step(|s| s.objects),
        to_boundary: step(|s| s.to_boundary),
        assemble: step(|s| s.assemble),
    }
}

/// One line per solver for the log.
fn record_line(r: &Record) -> String {
    format!(
        "  {:<10} frame {:>9.2} ms (direct {:.2}, objects {:.2}, to boundary {:.2}, assemble {:.2}), error {:.1} % after {} frames{}{}{}",
        r.solver.label(),
        r.frame_ms_median,
        r.step_ms.direct,
        r.step_ms.objects,
        r.step_ms.to_boundary,
        r.step_ms.assemble,
        100.0 * r.error.same_frames.overall,
        r.same_frames,
        if r.same_time_budget_ms > 0.0 {
            format!(
                ", {:.1} % after {} frames in {:.0} ms",
                100.0 * r.error.same_time.overall,
                r.same_time_frames,
                r.same_time_budget_ms
            )
        } else {
            String::new()
        },
        r.moving.as_ref().map_or(String::new(), |m| format!(
            "; moving {:.2} ms (direct {:.2}, objects {:.2}, to boundary {:.2}, assemble {:.2}; longest {:.1}), error while moving {:.1} / {:.1} / {:.1} %, {:.0} rays a frame = {:.2} ms at the floor rate ({:.1}x the floor)",
            m.frame_ms_median, m.step_ms.direct, m.step_ms.objects, m.step_ms.to_boundary, m.step_ms.assemble, m.frame_ms_max,
            100.0 * m.error.overall, 100.0 * m.error.boundary, 100.0 * m.error.interior,
            m.rays_median, m.ray_floor_ms, m.over_ray_floor
        )),
        if r.check == "ok" { String::new() } else { format!(", CHECK: {}", r.check) }
    )
}

/// The moving ratios of one scene for the log: the dispersive default's moving frame
/// against grid5's and grid5-r32's (issue 24 reads them from `--quick`). None without a
/// dispersive moving record or without either grid.
fn ratio_line(records: &[Record]) -> Option<String> {
    let moving = |k| {
        records
            .iter()
            .find(|r| r.solver == k)
            .and_then(|r| r.moving.as_ref())
    };
    let d = moving(SolverKind::Dispersive)?;
    if d.speedup_vs_grid5.is_none() && d.speedup_vs_grid5_r32.is_none() {
        return None;
    }
    let against = |k: SolverKind, x: Option<f64>| {
        moving(k).zip(x).map_or(format!("- vs {k}"), |(g, x)| {
            format!("{x:.1}x vs {k} ({:.1} ms)", g.frame_ms_median)
        })
    };
    Some(format!(
        "{} moving: dispersive {:.1} ms: {}, {}",
        records[0].scene,
        d.frame_ms_median,
        against(SolverKind::Grid5, d.speedup_vs_grid5),
        against(SolverKind::Grid5DefaultRes, d.speedup_vs_grid5_r32),
    ))
}

/// The objects scenes' ratio for the log: the moving frame with the most objects over that
/// with the fewest, from (interior objects, moving frame ms) pairs; None with fewer than
/// two counts or a zero frame.
fn objects_ratio(points: &[(usize, f64)]) -> Option<String> {
    let fewest = points.iter().min_by_key(|p| p.0)?;
    let most = points.iter().max_by_key(|p| p.0)?;
    (most.0 > fewest.0 && fewest.1 > 0.0).then(|| {
        format!(
            "objects: the moving frame with {} objects over that with {}: {:.1}x ({:.1} against {:.1} ms; issue 24 asks at most 1.5x)",
            most.0,
            fewest.0,
            most.1 / fewest.1,
            most.1,
            fewest.1
        )
    })
}

/// The speed-ups of one scene's records over grid5 and grid5-r32, still and moving.
fn set_speedups(records: &mut [Record]) {
    let still = |k| {
        records
            .iter()
            .find(|r| r.solver == k)
            .map(|r| r.frame_ms_median)
    };
    let moving = |k| {
        records
            .iter()
            .find(|r| r.solver == k)
            .and_then(|r| r.moving.as_ref())
            .map(|m| m.frame_ms_median)
    };
    let ratio = |g: Option<f64>, t: f64| g.filter(|_| t > 0.0).map(|g| g / t);
    let (g5, r32) = (still(SolverKind::Grid5), still(SolverKind::Grid5DefaultRes));
    let (g5m, r32m) = (
        moving(SolverKind::Grid5),
        moving(SolverKind::Grid5DefaultRes),
    );
    for r in records {
        r.speedup_vs_grid5 = ratio(g5, r.frame_ms_median);
        r.speedup_vs_grid5_r32 = ratio(r32, r.frame_ms_median);
        if let Some(m) = r.moving.as_mut() {
            m.speedup_vs_grid5 = ratio(g5m, m.frame_ms_median);
            m.speedup_vs_grid5_r32 = ratio(r32m, m.frame_ms_median);
        }
    }
}

/// One scene: its world and reference, the ray floor, then every solver of `kinds` in
/// turn; their records go to `records`. `machine` is logged with the first world.
#[allow(clippy::too_many_arguments)]
fn run_scene(
    spec: &SceneSpec,
    kinds: &[SolverKind],
    options: &BenchOptions,
    progress: &dyn Progress,
    log: &dyn Fn(&str),
    machine: &mut Option<Machine>,
    records: &mut Vec<Record>,
) -> Result<SceneInfo, Error> {
    let (rss0, _) = memory_mib();
    let t = Instant::now();
    let mut world = build_world(spec, options.backend)?;
    let world_seconds = t.elapsed().as_secs_f64();
    let world_rss_mib = memory_mib().0 - rss0;
    if machine.is_none() {
        let m = Machine::detect(world.vis.name());
        log(&format!("machine: {}", m.line()));
        *machine = Some(m);
    }
    progress.advance(1);
    // The ground truth every solver is measured against, checked like them.
    let t = Instant::now();
    let (reference, stats) = solve(&world, &options.reference, &NoProgress);
    let reference_seconds = t.elapsed().as_secs_f64();
    check_radiosity(&world, &reference)
        .map_err(|e| Error::Invalid(format!("reference on {}: {e}", spec.name)))?;
    let by_role = world.patches.count_by_role();
    log(&format!(
        "{}: {} patches (boundary {}, interior {}, light {}), world {:.1} s, reference {:.1} s ({} iterations{})",
        spec.name,
        world.patches.len(),
        by_role.0,
        by_role.1,
        by_role.2,
        world_seconds,
        reference_seconds,
        stats.iterations,
        if stats.converged { "" } else { ", NOT converged" }
    ));
    // The ray floor: the backend's rate in this scene, before any solver.
    let mut scene = SceneRun::new(spec, &reference, world_rss_mib);
    if options.ray_rate_rays > 0 {
        let (best, capture) = best_ray_rate(
            &world,
            options.ray_rate_rays,
            RAY_RATE_BATCH,
            RAY_RATE_REPEATS,
        );
        scene.ray_rate = best;
        let spread: Vec<String> = capture.iter().map(|r| format!("{:.1}", r * 1e-6)).collect();
        log(&format!(
            "{}: ray rate, best of {}: {} (capture measured {} Mrays/s)",
            spec.name,
            capture.len(),
            scene.ray_rate.line(),
            spread.join(", ")
        ));
    }
    progress.advance(1);
    let mut budget = None;
    let first = records.len();
    for &kind in kinds {
        let (r, back) = run_solver(world, &mut scene, kind, options, budget)?;
        world = back;
        if kind == SolverKind::Grid5 {
            budget = Some(r.same_time_budget_ms);
        }
        log(&record_line(&r));
        records.push(r);
        progress.advance(1);
    }
    set_speedups(&mut records[first..]);
    if let Some(line) = ratio_line(&records[first..]) {
        log(&line);
    }
    Ok(SceneInfo {
        scene: spec.name.clone(),
        patches: world.patches.len(),
        by_role,
        reference_seconds,
        reference_converged: stats.converged,
        world_seconds,
        ray_rate: scene.ray_rate,
        moved_references: scene.moved.solves,
        moved_reference_seconds: scene.moved.seconds,
    })
}

/// Run the whole benchmark. `log` receives one line per finished step, the machine's first.
pub fn run(
    options: &BenchOptions,
    progress: &dyn Progress,
    log: &dyn Fn(&str),
) -> Result<BenchReport, Error> {
    let start = Instant::now();
    let mut records: Vec<Record> = Vec::new();
    let mut infos = Vec::new();
    let mut machine = None;
    let units: u64 = options
        .scenes
        .iter()
        .map(|s| options.solvers_for(s).len() as u64)
        .filter(|&n| n > 0)
        .map(|n| 2 + n)
        .sum();
    progress.begin("bench", units);
    for spec in &options.scenes {
        let kinds = options.solvers_for(spec);
        if kinds.is_empty() {
            continue;
        }
        let info = run_scene(
            spec,
            &kinds,
            options,
            progress,
            log,
            &mut machine,
            &mut records,
        )?;
        infos.push(info);
    }
    let objects: Vec<(usize, f64)> = records
        .iter()
        .filter(|r| r.table == Table::Objects)
        .filter_map(|r| Some((r.interior_objects, r.moving.as_ref()?.frame_ms_median)))
        .collect();
    if let Some(line) = objects_ratio(&objects) {
        log(&line);
    }
    progress.end();
    Ok(BenchReport {
        machine: machine.unwrap_or_else(|| Machine::detect("none")),
        records,
        scenes: infos,
        reference_rays: options.reference.rays_per_patch,
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests;
