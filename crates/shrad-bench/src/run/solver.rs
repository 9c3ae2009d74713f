//! One solver's run over a scene's world: the still frames (the check after the warm-up,
//! the timed window, the errors after the same frames and the same time), then the moving
//! window, then its record.

use std::time::Instant;

use glam::Affine3A;
use shrad::engine::Engine;
use shrad::frame::FrameStats;
use shrad::metrics::{relative_error, RelativeError};
use shrad::scene::Role;
use shrad::{Error, World};

use super::{check_radiosity, median, step_medians, BenchOptions, SceneRun};
use crate::machine::{memory_mib, reset_peak};
use crate::moving::{mover, moving_frames, moving_window};
use crate::report::{Errors, Moving, Record, TracePoint};
use crate::scenes::{SceneSpec, Table};
use crate::solvers::SolverKind;

/// The frame counts and objects of one solver's run, fixed before it starts.
struct Plan {
    interior: Vec<usize>,
    /// Table 3: the grown object (the first interior one); else the largest.
    largest_object: Option<usize>,
    /// The object moved in the moving window.
    mover: Option<usize>,
    /// Patches of `largest_object`.
    largest: usize,
    /// Interior objects, at least 1.
    n_obj: usize,
    same_frames: usize,
    warmup: usize,
    timed: usize,
}

impl Plan {
    fn new(world: &World, spec: &SceneSpec, kind: SolverKind, options: &BenchOptions) -> Self {
        let p = &world.patches;
        let interior: Vec<usize> = (0..p.object_role.len())
            .filter(|&o| p.object_role[o] == Role::Interior)
            .collect();
        let largest_object = match spec.table {
            Table::BigObject => interior.first().copied(),
            Table::Scaling | Table::Objects => {
                interior.iter().copied().max_by_key(|&o| p.range(o).len())
            }
        };
        let mover = mover(world, spec.table, &interior);
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
        Plan {
            interior,
            largest_object,
            mover,
            largest,
            n_obj,
            same_frames,
            warmup,
            timed,
        }
    }
}

/// What the still frames measured.
struct StillFrames {
    timed_stats: Vec<FrameStats>,
    err_same_frames: Option<RelativeError>,
    err_same_time: Option<RelativeError>,
    budget: Option<f64>,
    same_time_frames: usize,
    trace: Vec<TracePoint>,
    solver_rss: f64,
    check: String,
}

/// Step `engine` on the still scene: the check after the warm-up, the timed window, the
/// error after the same frames and at the same time as grid5, and the error trace.
fn still_frames(
    engine: &mut Engine,
    scene: &SceneRun<'_>,
    kind: SolverKind,
    options: &BenchOptions,
    plan: &Plan,
    budget_ms: Option<f64>,
    rss0: f64,
) -> Result<StillFrames, Error> {
    let spec = scene.spec;
    let (warmup, timed, same_frames) = (plan.warmup, plan.timed, plan.same_frames);
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
        let mut err = || *error.get_or_insert_with(|| error_now(engine));
        if frames == warmup.max(1) {
            // The check comes before the timed window.
            solver_rss = memory_mib().0 - rss0;
            check = warmup_check(engine, &mut err, kind, spec, options, frames)?;
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
            error: error_now(engine).overall,
        });
    }
    if err_same_time.is_none() {
        // The frame cap came first: report the last state.
        err_same_time = Some(error_now(engine));
        same_time_frames = frames;
    }
    Ok(StillFrames {
        timed_stats,
        err_same_frames,
        err_same_time,
        budget,
        same_time_frames,
        trace,
        solver_rss,
        check,
    })
}

/// The check after the warm-up: a usable radiosity (else an error) and an error against
/// the reference within the bound (else the record says so).
fn warmup_check(
    engine: &Engine,
    err: &mut dyn FnMut() -> RelativeError,
    kind: SolverKind,
    spec: &SceneSpec,
    options: &BenchOptions,
    frames: usize,
) -> Result<String, Error> {
    check_radiosity(engine.world(), engine.radiosity())
        .map_err(|e| Error::Invalid(format!("{kind} on {}: {e}", spec.name)))?;
    let e = err();
    let within = e.overall <= options.error_bound; // false for NaN
    Ok(if within {
        String::from("ok")
    } else {
        format!(
            "error {:.1} % after {frames} warm-up frames exceeds {:.0} %",
            100.0 * e.overall,
            100.0 * options.error_bound
        )
    })
}

/// The case the paper is about: an object moving every frame. The still frames are cheap
/// once the exact caches of Steps 1-3 hold; these frames pay for the object's light, its
/// shadows and its neighbours again. Returns the window and where the mover rested.
#[allow(clippy::type_complexity)]
fn moving_frames_of(
    engine: &mut Engine,
    scene: &mut SceneRun<'_>,
    kind: SolverKind,
    options: &BenchOptions,
    plan: &Plan,
) -> Result<(Option<Moving>, Option<(usize, Affine3A)>), Error> {
    let spec = scene.spec;
    let asked = if spec.table == Table::Objects {
        options.objects_moving_frames
    } else if kind.is_grid() {
        options.grid_moving
    } else {
        options.dispersive_moving_passes * plan.n_obj
    };
    let moving_frames = moving_frames(asked);
    let mover = plan.mover.filter(|_| moving_frames > 0);
    let rest = mover.map(|o| (o, engine.world().patches.world_from_local[o]));
    let moving = match mover {
        Some(o) => Some(
            moving_window(
                engine,
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
    Ok((moving, rest))
}

/// Run one solver on an engine over `world` and hand the world back. `budget_ms`: the
/// same-time budget (None for grid5, which sets it from its own first frames and returns it).
pub(super) fn run_solver(
    world: World,
    scene: &mut SceneRun<'_>,
    kind: SolverKind,
    options: &BenchOptions,
    budget_ms: Option<f64>,
) -> Result<(Record, World), Error> {
    let spec = scene.spec;
    let plan = Plan::new(&world, spec, kind, options);
    let patches = world.patches.len();
    let peak_reset = reset_peak();
    let (rss0, _) = memory_mib();
    let t = Instant::now();
    let mut engine = Engine::from_world(world, kind.choice())?;
    let setup_ms = t.elapsed().as_secs_f64() * 1e3;
    let still = still_frames(&mut engine, scene, kind, options, &plan, budget_ms, rss0)?;
    let (moving, rest) = moving_frames_of(&mut engine, scene, kind, options, &plan)?;
    let timed_stats = &still.timed_stats;
    let frame_ms: Vec<f64> = timed_stats.iter().map(|s| s.frame_ms).collect();
    // The paper's Table 3 column: the frames that update the largest object.
    let largest_frames: Vec<f64> = timed_stats
        .iter()
        .filter(|s| {
            plan.largest_object
                .is_some_and(|o| s.objects_updated.contains(&o))
        })
        .map(|s| s.frame_ms)
        .collect();
    let (_, hwm) = memory_mib();
    let record = Record {
        scene: spec.name.clone(),
        table: spec.table,
        patches,
        largest_object_patches: plan.largest,
        interior_objects: plan.interior.len(),
        solver: kind,
        frame_ms_median: median(&frame_ms),
        largest_object_frame_ms: if largest_frames.is_empty() {
            f64::NAN
        } else {
            median(&largest_frames)
        },
        step_ms: step_medians(timed_stats),
        warmup_frames: plan.warmup,
        timed_frames: timed_stats.len(),
        error: Errors {
            same_frames: still.err_same_frames.unwrap_or_default(),
            same_time: still.err_same_time.unwrap_or_default(),
        },
        same_frames: plan.same_frames,
        same_time_budget_ms: still.budget.unwrap_or(0.0),
        same_time_frames: still.same_time_frames,
        speedup_vs_grid5: None,
        speedup_vs_grid5_r32: None,
        setup_ms,
        peak_mib: hwm,
        peak_is_per_solver: peak_reset,
        solver_peak_mib: if peak_reset { hwm - rss0 } else { f64::NAN },
        solver_rss_mib: still.solver_rss,
        world_rss_mib: scene.world_rss_mib,
        check: still.check,
        trace: still.trace,
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
