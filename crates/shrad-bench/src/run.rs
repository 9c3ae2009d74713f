//! Running the protocol: for each scene one world and one reference solve, then each solver
//! in turn on an [`Engine`] over that world, checked before it is timed.

use std::time::Instant;

use glam::{Affine3A, Vec3};
use shrad::dispersive::FrameStats;
use shrad::engine::Engine;
use shrad::metrics::relative_error;
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::Role;
use shrad::vis::Backend;
use shrad::{Error, NoProgress, Progress, World};

use crate::machine::{memory_mib, reset_peak, Machine};
use crate::report::{BenchReport, Errors, Moving, Record, SceneInfo, StepMs, TracePoint};
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
}

/// How far the moving object goes either side of where it rests, as a fraction of the
/// scene's extent along x (0.4 m in the 8 m room).
pub const MOVE_REACH: f32 = 0.05;
/// Frames of one back-and-forth of the moving object.
pub const MOVE_PERIOD_FRAMES: usize = 16;

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
        }
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
}

/// Run one solver on an engine over `world` and hand the world back. `budget_ms`: the
/// same-time budget (None for grid5, which sets it from its own first frames and returns it).
fn run_solver(
    world: World,
    scene: &SceneRun<'_>,
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
        Table::Scaling => interior.iter().copied().max_by_key(|&o| p.range(o).len()),
    };
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
    let moving_frames = if kind.is_grid() {
        options.grid_moving
    } else {
        options.dispersive_moving_passes * n_obj
    };
    let mover = largest_object.filter(|_| moving_frames > 0);
    let rest = mover.map(|o| (o, engine.world().patches.world_from_local[o]));
    let moving_stats = match mover {
        Some(o) => time_moving(&mut engine, o, moving_frames).map_err(|e| {
            Error::Invalid(format!("{kind} on {} with a moving object: {e}", spec.name))
        })?,
        None => Vec::new(),
    };
    let moving = (!moving_stats.is_empty()).then(|| medians(&moving_stats));
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

/// Step `frames` frames, moving object `o` before each: back and forth along x by
/// [`MOVE_REACH`] of the scene's extent, one period in [`MOVE_PERIOD_FRAMES`] frames. The
/// radiosity is checked after the last frame.
fn time_moving(engine: &mut Engine, o: usize, frames: usize) -> Result<Vec<FrameStats>, String> {
    let rest = engine.transform(o);
    let size = engine
        .world()
        .scene
        .bounds()
        .ok_or_else(|| "the scene is empty".to_string())?
        .size();
    let reach = MOVE_REACH * size.x;
    let mut stats = Vec::with_capacity(frames);
    for k in 1..=frames {
        let phase = (k as f32 * std::f32::consts::TAU / MOVE_PERIOD_FRAMES as f32).sin();
        engine
            .set_transform(
                o,
                Affine3A::from_translation(Vec3::X * reach * phase) * rest,
            )
            .map_err(|e| e.to_string())?;
        stats.push(engine.step());
    }
    check_radiosity(engine.world(), engine.radiosity())?;
    Ok(stats)
}

/// The median of each step over `stats`, taken separately.
fn step_medians(stats: &[FrameStats]) -> StepMs {
    let steps: Vec<StepMs> = stats.iter().map(StepMs::of).collect();
    let step = |f: fn(&StepMs) -> f64| median(&steps.iter().map(f).collect::<Vec<_>>());
    StepMs {
        direct: step(|s| s.direct),
        objects: step(|s| s.objects),
        to_boundary: step(|s| s.to_boundary),
        assemble: step(|s| s.assemble),
    }
}

/// The medians of a window of frames with an object moving.
fn medians(stats: &[FrameStats]) -> Moving {
    Moving {
        frame_ms_median: median(&stats.iter().map(|s| s.frame_ms).collect::<Vec<_>>()),
        frame_ms_max: stats.iter().map(|s| s.frame_ms).fold(0.0, f64::max),
        step_ms: step_medians(stats),
        frames: stats.len(),
        speedup_vs_grid5: None,
    }
}

/// One line per solver for the log.
fn record_line(r: &Record) -> String {
    format!(
        "  {:<10} frame {:>9.2} ms (direct {:.2}, objects {:.2}, to boundary {:.2}, assemble {:.2}), error {:.1} % after {} frames, {:.1} % after {} frames in {:.0} ms{}{}",
        r.solver.label(),
        r.frame_ms_median,
        r.step_ms.direct,
        r.step_ms.objects,
        r.step_ms.to_boundary,
        r.step_ms.assemble,
        100.0 * r.error.same_frames.overall,
        r.same_frames,
        100.0 * r.error.same_time.overall,
        r.same_time_frames,
        r.same_time_budget_ms,
        r.moving.as_ref().map_or(String::new(), |m| format!(
            "; moving {:.2} ms (direct {:.2}, objects {:.2}, to boundary {:.2}, assemble {:.2}; longest {:.1})",
            m.frame_ms_median, m.step_ms.direct, m.step_ms.objects, m.step_ms.to_boundary, m.step_ms.assemble, m.frame_ms_max
        )),
        if r.check == "ok" { String::new() } else { format!(", CHECK: {}", r.check) }
    )
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
    let units = options.scenes.len() as u64 * (2 + options.solvers.len() as u64);
    progress.begin("bench", units);
    for spec in &options.scenes {
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
        infos.push(SceneInfo {
            scene: spec.name.clone(),
            patches: world.patches.len(),
            by_role,
            reference_seconds,
            reference_converged: stats.converged,
            world_seconds,
        });
        progress.advance(1);
        let scene = SceneRun {
            spec,
            reference: &reference,
            world_rss_mib,
        };
        let mut budget = None;
        let first = records.len();
        for &kind in &options.solvers {
            let (r, back) = run_solver(world, &scene, kind, options, budget)?;
            world = back;
            if kind == SolverKind::Grid5 {
                budget = Some(r.same_time_budget_ms);
            }
            log(&record_line(&r));
            records.push(r);
            progress.advance(1);
        }
        // Speed-ups within the scene.
        let grid5 = records[first..]
            .iter()
            .find(|r| r.solver == SolverKind::Grid5)
            .map(|r| r.frame_ms_median);
        if let Some(g) = grid5 {
            for r in &mut records[first..] {
                if r.frame_ms_median > 0.0 {
                    r.speedup_vs_grid5 = Some(g / r.frame_ms_median);
                }
            }
        }
        let grid5_moving = records[first..]
            .iter()
            .find(|r| r.solver == SolverKind::Grid5)
            .and_then(|r| r.moving.as_ref())
            .map(|m| m.frame_ms_median);
        if let Some(g) = grid5_moving {
            for m in records[first..]
                .iter_mut()
                .filter_map(|r| r.moving.as_mut())
            {
                if m.frame_ms_median > 0.0 {
                    m.speedup_vs_grid5 = Some(g / m.frame_ms_median);
                }
            }
        }
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
    fn solvers_run_in_the_canonical_order() {
        let mut o = BenchOptions::new(true);
        o.set_solvers(&[SolverKind::Paper, SolverKind::Grid5, SolverKind::Paper]);
        assert_eq!(o.solvers, vec![SolverKind::Grid5, SolverKind::Paper]);
    }

    #[test]
    fn small_room_runs_every_solver() {
        let spec = SceneSpec {
            name: "tiny".into(),
            table: Table::Scaling,
            params: RoomParams {
                objects: 2,
                patches: 1500,
                big_object_patches: None,
            },
        };
        let mut options = BenchOptions::new(true);
        options.scenes = vec![spec];
        options.reference = ReferenceOptions::fast();
        options.grid_timed = 2;
        options.grid_warmup = 1;
        options.same_time_grid5_frames = 2;
        // The kinds fix the paper's settings (cube maps of 128): keep it to one scene of
        // 1500 patches.
        let lines = std::sync::Mutex::new(Vec::new());
        let report = run(&options, &NoProgress, &|l| {
            lines.lock().unwrap().push(l.to_string())
        })
        .unwrap();
        assert_eq!(report.records.len(), SolverKind::ALL.len());
        for r in &report.records {
            assert!(r.frame_ms_median > 0.0, "{r:?}");
            assert!(r.error.same_frames.overall.is_finite(), "{r:?}");
            assert!(r.error.same_time.overall.is_finite(), "{r:?}");
            assert!(r.same_time_frames >= 1);
            assert_eq!(r.check, "ok");
        }
        assert!(report.records.iter().all(|r| r.speedup_vs_grid5.is_some()));
        // Every solver also timed frames with an object moving.
        for r in &report.records {
            let m = r.moving.as_ref().expect("a moving window");
            assert!(m.frames >= 1 && m.frame_ms_median > 0.0, "{r:?}");
            assert!(m.speedup_vs_grid5.is_some(), "{r:?}");
        }
        // The machine comes first in the log.
        assert!(lines.lock().unwrap()[0].starts_with("machine: CPU "));
        let md = crate::markdown(&report, "test");
        assert!(md.contains("| tiny |"));
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
        let scene = SceneRun {
            spec: &spec,
            reference: &reference,
            world_rss_mib: 0.0,
        };
        let mut options = BenchOptions::new(true);
        options.dispersive_moving_passes = 3;
        let (record, world) =
            run_solver(world, &scene, SolverKind::Dispersive, &options, Some(1.0)).unwrap();
        let m = record.moving.expect("a moving window");
        assert_eq!(m.frames, 6);
        assert!(m.frame_ms_max >= m.frame_ms_median);
        assert_eq!(world.patches.centre, centres);
        assert_eq!(world.patches.normal, normals);
    }
}
