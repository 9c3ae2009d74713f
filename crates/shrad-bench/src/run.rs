//! Running the protocol: for each scene one world and one reference solve, then each solver
//! in turn on an [`Engine`] over that world, checked before it is timed.

use std::time::Instant;

use glam::Vec3;
use shrad::dispersive::FrameStats;
use shrad::engine::Engine;
use shrad::metrics::relative_error;
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::Role;
use shrad::vis::Backend;
use shrad::{Error, NoProgress, Progress, World};

use crate::machine::{memory_mib, reset_peak, Machine};
use crate::moving::{mover, moving_frames, moving_window, MovedReferences};
use crate::rays::{measure_ray_rate, RayRate, RAY_RATE_BATCH, RAY_RATE_RAYS};
use crate::report::{BenchReport, Errors, Record, SceneInfo, StepMs, TracePoint};
use crate::scenes::{build_world, scenes, SceneSpec, Table};
use crate::solvers::SolverKind;

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
    /// Dispersive: passes timed with one object moving every frame.
    pub dispersive_moving_passes: usize,
    /// The objects scenes ([`Table::Objects`]): frames timed with the smallest box moving
    /// (a fixed count, not passes: a pass of 128 objects would be 128 moving frames).
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
            dispersive_moving_passes: 2,
            objects_moving_frames: if quick { 12 } else { 36 },
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

/// Run one solver on an engine over `world` and hand the world back. `budget_ms`: the
/// same-time budget (None for grid5, which sets it from its own first frames and returns it).
fn run_solver(
    world: World,
    scene: &mut SceneRun<'_>,
    kind: SolverKind,
    options: &BenchOptions,
    budget_ms: Option<f64>,
) -> Result<(Record, World), Error> {
    let spec = scene.spec;
    let p = &world.patches;
    let interior: Vec<usize> = (0..p.object_role.len())
        .filter(|&o| p.object_role[o] == Role::Interior)
        .collect();
    // Table 3: the grown object (the first interior one); else the largest.
    let largest_object = match spec.table {
        Table::BigObject => interior.first().copied(),
        Table::Scaling | Table::Objects => {
            interior.iter().copied().max_by_key(|&o| p.range(o).len())
        }
    };
    let mover = mover(&world, spec.table, &interior);
    let largest = largest_object.map_or(0, |o| p.range(o).len());
    let n_obj = interior.len().max(1);
    let same_frames = if options.same_frames > 0 {
        options.same_frames
    } else {
        2 * n_obj
    };
    let (warmup, timed) = if kind.is_grid() {
        (options.grid_warmup, options.grid_timed.max(1))
    } else {
        (
            options.dispersive_warmup_passes * n_obj,
            (options.dispersive_timed_passes * n_obj).max(1),
        )
    };
    let patches = p.len();
    let peak_reset = reset_peak();
    let (rss0, _) = memory_mib();
    let t = Instant::now();
    let mut engine = Engine::from_world(world, kind.choice())?;
    let setup_ms = t.elapsed().as_secs_f64() * 1e3;
    let error_now = |e: &Engine| relative_error(&e.world().patches, e.radiosity(), scene.reference);
    let mut cum_ms = 0.0;
    let mut frames = 0usize;
    let mut timed_stats: Vec<FrameStats> = Vec::with_capacity(timed);
    let mut err_same_frames = None;
    let mut err_same_time = None;
    let mut budget = budget_ms;
    let mut same_time_frames = 0;
    let mut trace = Vec::new();
    let mut solver_rss = 0.0;
    let mut check = String::from("ok");
    let mut next_trace = 1usize;
    loop {
        let s = engine.step();
        frames += 1;
        cum_ms += s.frame_ms;
        if frames > warmup && timed_stats.len() < timed {
            timed_stats.push(s);
        }
        let mut error = None;
        let mut err = || *error.get_or_insert_with(|| error_now(&engine));
        if frames == warmup.max(1) {
            // The check comes before the timed window.
            solver_rss = memory_mib().0 - rss0;
            check_radiosity(engine.world(), engine.radiosity())
                .map_err(|e| Error::Invalid(format!("{kind} on {}: {e}", spec.name)))?;
            let e = err();
            let within = e.overall <= options.error_bound; // false for NaN
            if !within {
                check = format!(
                    "error {:.1} % after {frames} warm-up frames exceeds {:.0} %",
                    100.0 * e.overall,
                    100.0 * options.error_bound
                );
            }
        }
        if frames == same_frames {
            err_same_frames = Some(err());
        }
        if kind == SolverKind::Grid5
            && budget.is_none()
            && frames == options.same_time_grid5_frames.max(1)
        {
            budget = Some(cum_ms);
        }
        if err_same_time.is_none() {
            if let Some(b) = budget {
                if cum_ms >= b - 1e-9 {
                    err_same_time = Some(err());
                    same_time_frames = frames;
                }
            }
        }
        // Trace: every frame for the first 16, then geometrically spaced.
        if frames >= next_trace {
            trace.push(TracePoint {
                frames,
                ms: cum_ms,
                error: err().overall,
            });
            next_trace = if frames < 16 {
                frames + 1
            } else {
                (frames as f64 * 1.12).ceil() as usize
            };
        }
        let done = timed_stats.len() >= timed
            && err_same_frames.is_some()
            && (err_same_time.is_some() || budget.is_none());
        if done || frames >= options.max_frames {
            break;
        }
    }
    if trace.last().is_none_or(|t| t.frames != frames) {
        trace.push(TracePoint {
            frames,
            ms: cum_ms,
            error: error_now(&engine).overall,
        });
    }
    if err_same_time.is_none() {
        // The frame cap came first: report the last state.
        err_same_time = Some(error_now(&engine));
        same_time_frames = frames;
    }
    // The case the paper is about: an object moving every frame. The static frames above
    // are cheap once the exact caches of Steps 1-3 hold; these frames pay for the object's
    // light, its shadows and its neighbours again.
    let asked = if spec.table == Table::Objects {
        options.objects_moving_frames
    } else if kind.is_grid() {
        options.grid_moving
    } else {
        options.dispersive_moving_passes * n_obj
    };
    let moving_frames = moving_frames(asked);
    let mover = mover.filter(|_| moving_frames > 0);
    let rest = mover.map(|o| (o, engine.world().patches.world_from_local[o]));
    let moving = match mover {
        Some(o) => Some(
            moving_window(
                &mut engine,
                o,
                moving_frames,
                &mut scene.moved,
                &options.reference,
                &scene.ray_rate,
            )
            .map_err(|e| Error::Invalid(format!("{kind} on {}: {e}", spec.name)))?,
        ),
        None => None,
    };
    let frame_ms: Vec<f64> = timed_stats.iter().map(|s| s.frame_ms).collect();
    // The paper's Table 3 column: the frames that update the largest object.
    let largest_frames: Vec<f64> = timed_stats
        .iter()
        .filter(|s| largest_object.is_some_and(|o| s.objects_updated.contains(&o)))
        .map(|s| s.frame_ms)
        .collect();
    let (_, hwm) = memory_mib();
    let record = Record {
        scene: spec.name.clone(),
        table: spec.table,
        patches,
        largest_object_patches: largest,
        interior_objects: interior.len(),
        solver: kind,
        frame_ms_median: median(&frame_ms),
        largest_object_frame_ms: if largest_frames.is_empty() {
            f64::NAN
        } else {
            median(&largest_frames)
        },
        step_ms: step_medians(&timed_stats),
        warmup_frames: warmup,
        timed_frames: timed_stats.len(),
        error: Errors {
            same_frames: err_same_frames.unwrap_or_default(),
            same_time: err_same_time.unwrap_or_default(),
        },
        same_frames,
        same_time_budget_ms: budget.unwrap_or(0.0),
        same_time_frames,
        speedup_vs_grid5: None,
        speedup_vs_grid5_r32: None,
        setup_ms,
        peak_mib: hwm,
        peak_is_per_solver: peak_reset,
        solver_peak_mib: if peak_reset { hwm - rss0 } else { f64::NAN },
        solver_rss_mib: solver_rss,
        world_rss_mib: scene.world_rss_mib,
        check,
        trace,
        moving,
    };
    // The solver is dropped here, before the next one is built (the memory columns), and the
    // moved object goes back exactly where it rested (its local transform, not a round trip
    // through the object's), so that the next solver starts from the same world.
    let mut world = engine.into_world();
    if let Some((o, xf)) = rest {
        world.patches.set_transform(o, xf);
        world.vis.set_transform(o, xf);
        world.vis.commit();
    }
    Ok((record, world))
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
        let (rss0, _) = memory_mib();
        let t = Instant::now();
        let mut world = build_world(spec, options.backend)?;
        let world_seconds = t.elapsed().as_secs_f64();
        let world_rss_mib = memory_mib().0 - rss0;
        if machine.is_none() {
            let m = Machine::detect(world.vis.name());
            log(&format!("machine: {}", m.line()));
            machine = Some(m);
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
            scene.ray_rate = measure_ray_rate(&world, options.ray_rate_rays, RAY_RATE_BATCH);
            log(&format!(
                "{}: ray rate {}",
                spec.name,
                scene.ray_rate.line()
            ));
        }
        progress.advance(1);
        let mut budget = None;
        let first = records.len();
        for &kind in &kinds {
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
        infos.push(SceneInfo {
            scene: spec.name.clone(),
            patches: world.patches.len(),
            by_role,
            reference_seconds,
            reference_converged: stats.converged,
            world_seconds,
            ray_rate: scene.ray_rate,
            moved_references: scene.moved.solves,
            moved_reference_seconds: scene.moved.seconds,
        });
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
mod tests {
    use super::*;
    use shrad::scene::RoomParams;

    #[test]
    fn median_of_even_and_odd() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
    }

    #[test]
    fn the_objects_ratio_is_the_most_over_the_fewest() {
        let line = objects_ratio(&[(32, 90.0), (128, 150.0), (8, 50.0)]).unwrap();
        assert!(
            line.contains("with 128 objects over that with 8: 3.0x"),
            "{line}"
        );
        assert!(objects_ratio(&[(8, 50.0)]).is_none());
        assert!(objects_ratio(&[(8, 0.0), (128, 1.0)]).is_none());
        assert!(objects_ratio(&[]).is_none());
    }

    #[test]
    fn solvers_run_in_the_canonical_order() {
        let mut o = BenchOptions::new(true);
        o.set_solvers(&[SolverKind::Paper, SolverKind::Grid5, SolverKind::Paper]);
        assert_eq!(o.solvers, vec![SolverKind::Grid5, SolverKind::Paper]);
    }

    #[test]
    fn small_room_runs_every_solver() {
        let mut objects = tiny_spec(Table::Objects, 3, 1500);
        objects.name = "tiny-objects".into();
        let mut options = BenchOptions::new(true);
        options.scenes = vec![tiny_spec(Table::Scaling, 2, 1500), objects];
        options.reference = ReferenceOptions::fast();
        options.grid_timed = 2;
        options.grid_warmup = 1;
        options.same_time_grid5_frames = 2;
        options.objects_moving_frames = 4;
        options.ray_rate_rays = 20_000;
        // The kinds fix the paper's settings (cube maps of 128): keep it to one scene of
        // 1500 patches.
        let lines = std::sync::Mutex::new(Vec::new());
        let report = run(&options, &NoProgress, &|l| {
            lines.lock().unwrap().push(l.to_string())
        })
        .unwrap();
        // Every solver on the room, the dispersive default alone on the objects scene.
        assert_eq!(report.records.len(), SolverKind::ALL.len() + 1);
        let (room, objects): (Vec<&Record>, Vec<&Record>) =
            report.records.iter().partition(|r| r.scene == "tiny");
        assert_eq!(objects.len(), 1);
        assert_eq!(objects[0].solver, SolverKind::Dispersive);
        assert_eq!(objects[0].interior_objects, 3);
        for r in &report.records {
            assert!(r.frame_ms_median > 0.0, "{r:?}");
            assert!(r.error.same_frames.overall.is_finite(), "{r:?}");
            assert!(r.error.same_time.overall.is_finite(), "{r:?}");
            assert!(r.same_time_frames >= 1);
            assert_eq!(r.check, "ok");
        }
        assert!(room.iter().all(|r| r.speedup_vs_grid5.is_some()));
        assert!(room.iter().all(|r| r.speedup_vs_grid5_r32.is_some()));
        // Every solver also timed frames with an object moving, with the error of the last
        // and its rays against the floor.
        for r in &report.records {
            let m = r.moving.as_ref().expect("a moving window");
            assert!(m.frames >= 1 && m.frame_ms_median > 0.0, "{r:?}");
            assert!(m.error.overall.is_finite(), "{r:?}");
            assert!(m.ray_floor_ms > 0.0 && m.over_ray_floor > 0.0, "{r:?}");
        }
        for r in &room {
            let m = r.moving.as_ref().unwrap();
            assert!(m.speedup_vs_grid5.is_some(), "{r:?}");
            assert!(m.speedup_vs_grid5_r32.is_some(), "{r:?}");
        }
        assert!(report
            .scenes
            .iter()
            .all(|i| i.ray_rate.closest_rays == 20_000));
        assert!(report.scenes.iter().all(|i| i.moved_references >= 1));
        let lines = lines.lock().unwrap();
        // The machine comes first in the log, and the moving ratios are said.
        assert!(lines[0].starts_with("machine: CPU "));
        assert!(
            lines
                .iter()
                .any(|l| l.starts_with("tiny moving: dispersive ")
                    && l.contains("x vs grid5 (")
                    && l.contains("x vs grid5-r32 (")),
            "{lines:?}"
        );
        assert!(lines.iter().any(|l| l.contains("error while moving")));
        let md = crate::markdown(&report, "test");
        assert!(md.contains("| tiny |"));
        assert!(
            md.contains("faster than the G = 5 grid at 32^2 (grid5-r32)"),
            "{md}"
        );
        assert!(
            md.contains("## Objects") && md.contains("| tiny-objects |"),
            "{md}"
        );
        assert!(md.contains("## While moving"), "{md}");
        // Every table's rows have as many cells as its header.
        let mut cells = None;
        for l in md.lines() {
            if l.starts_with('|') {
                let n = l.matches('|').count();
                assert_eq!(*cells.get_or_insert(n), n, "{l}");
            } else {
                cells = None;
            }
        }
        let plots = crate::plots::plots(&report);
        let by_objects = plots.iter().find(|p| p.name == "time_vs_objects").unwrap();
        assert_eq!(by_objects.series.len(), 1);
        assert_eq!(by_objects.series[0].points.len(), 1);
        assert_eq!(by_objects.series[0].points[0].0, 3.0);
        // moving.csv: a header and one row of every column per moving record.
        let dir = std::env::temp_dir().join(format!("shrad-bench-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        crate::write_outputs(&report, &dir, "test", &|_| {}).unwrap();
        let csv = std::fs::read_to_string(dir.join("moving.csv")).unwrap();
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows.len(), 1 + report.records.len(), "{csv}");
        assert!(rows[0].starts_with("scene,table,solver,") && rows[0].contains("error_overall"));
        let columns = rows[0].split(',').count();
        assert!(
            rows.iter().all(|r| r.split(',').count() == columns),
            "{csv}"
        );
        assert!(dir.join("time_vs_objects.csv").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn tiny_spec(table: Table, objects: usize, patches: usize) -> SceneSpec {
        SceneSpec {
            name: "tiny".into(),
            table,
            params: RoomParams {
                objects,
                patches,
                big_object_patches: None,
            },
        }
    }

    /// Through `run_solver`: the moved reference is of a moved state (not of the rest the
    /// object goes back to) and two solvers whose windows end at the same place share it.
    #[test]
    fn run_solver_measures_the_error_while_moving() {
        let spec = tiny_spec(Table::Scaling, 2, 1200);
        let world = build_world(&spec, Backend::Auto).unwrap();
        let mut options = BenchOptions::new(true);
        options.reference = ReferenceOptions::fast();
        let (reference, _) = solve(&world, &options.reference, &NoProgress);
        let mut scene = SceneRun::new(&spec, &reference, 0.0);
        scene.ray_rate = measure_ray_rate(&world, 20_000, 4_096);
        let (record, world) = run_solver(
            world,
            &mut scene,
            SolverKind::Dispersive,
            &options,
            Some(1.0),
        )
        .unwrap();
        let m = record.moving.expect("a moving window");
        assert!(
            m.error.overall.is_finite() && m.error.overall > 0.0,
            "{m:?}"
        );
        assert!(m.object.starts_with("box_") || m.object.starts_with("sphere_"));
        assert!(m.rays_median > 0.0 && m.ray_floor_ms > 0.0, "{m:?}");
        assert!((m.over_ray_floor - m.frame_ms_median / m.ray_floor_ms).abs() < 1e-9);
        let moved = scene.moved.last.as_ref().expect("a moved reference");
        assert_ne!(
            moved.world_from_local, world.patches.world_from_local[moved.object],
            "the reference was solved at rest"
        );
        assert!(moved
            .radiosity
            .iter()
            .zip(&reference)
            .any(|(a, b)| (*a - *b).abs().max_element() > 1e-4));
        assert_eq!(scene.moved.solves, 1);
        // The paper preset ends its window at the same place: the reference is shared.
        let (_, _world) =
            run_solver(world, &mut scene, SolverKind::Paper, &options, Some(1.0)).unwrap();
        assert_eq!(scene.moved.solves, 1);
    }

    #[test]
    fn the_moved_object_goes_back_where_it_rested() {
        let spec = SceneSpec {
            name: "tiny".into(),
            table: Table::Scaling,
            params: RoomParams {
                objects: 2,
                patches: 1200,
                big_object_patches: None,
            },
        };
        let world = build_world(&spec, Backend::Auto).unwrap();
        let centres = world.patches.centre.clone();
        let normals = world.patches.normal.clone();
        let (reference, _) = solve(&world, &ReferenceOptions::fast(), &NoProgress);
        let mut scene = SceneRun::new(&spec, &reference, 0.0);
        let mut options = BenchOptions::new(true);
        options.reference = ReferenceOptions::fast();
        options.dispersive_moving_passes = 3;
        let (record, world) = run_solver(
            world,
            &mut scene,
            SolverKind::Dispersive,
            &options,
            Some(1.0),
        )
        .unwrap();
        let m = record.moving.expect("a moving window");
        // 3 passes of 2 objects, run on to the sweep's next turning point.
        assert_eq!(m.frames, moving_frames(6));
        assert!(m.frame_ms_max >= m.frame_ms_median);
        assert_eq!(world.patches.centre, centres);
        assert_eq!(world.patches.normal, normals);
    }
}
