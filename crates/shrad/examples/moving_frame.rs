//! Profile the moving frame (issue 24): the built-in room at `patches` patches with
//! `objects` interior objects, converged, then its largest interior object moved back and
//! forth along x before every frame (as `shrad bench` does), and then left still. Prints the
//! medians of the frame and of each step, the rays cast, and the still frames after.
//!
//! `cargo run --release --example moving_frame [patches] [objects] [frames] [budget_ms|-] [key=value ...] [error] [smallest] [built] [point] [sky]`
use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::frame::FrameStats;
use shrad::scene::{room, Light, LightKind, Role, RoomParams};
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::PatchSizing;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn report(label: &str, stats: &[FrameStats]) {
    let d = |f: fn(&shrad::frame::DispersiveStats) -> f64| {
        median(stats.iter().filter_map(|s| s.dispersive().map(f)).collect())
    };
    println!(
        "{label}: frame {:.2} ms (mean {:.2}, max {:.2}), direct {:.2}, objects {:.2}, to boundary {:.2}, assemble {:.2}; rays {:.0} (mean {:.0})",
        median(stats.iter().map(|s| s.frame_ms).collect()),
        mean(stats.iter().map(|s| s.frame_ms)),
        stats.iter().map(|s| s.frame_ms).fold(0.0, f64::max),
        d(|s| s.direct_ms),
        d(|s| s.objects_ms),
        d(|s| s.to_boundary_ms),
        d(|s| s.assemble_ms),
        median(stats.iter().map(|s| s.rays_cast as f64).collect()),
        mean(stats.iter().map(|s| s.rays_cast as f64)),
    );
}

/// CPU time of every thread of this process so far (ns; Linux's per-task schedstat), or 0
/// where it cannot be read: on a loaded machine a frame's CPU time says more than its wall
/// time.
fn cpu_ns() -> u64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0;
    };
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    sum / n.max(1) as f64
}

fn main() {
    let mut args = std::env::args().skip(1);
    let patches: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(77_000);
    let objects: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(8);
    let frames: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(32);
    // With a budget (ms), the moving frames are `Engine::step_within` it, and their 95th
    // percentile is printed against it.
    let budget: Option<f32> = args.next().and_then(|s| s.parse().ok());
    // Then any number of solver settings, `key=value`.
    // and `error`: the error of the last moving frame against a reference solve of that
    // moved state.
    let rest: Vec<String> = args.collect();
    let settings: Vec<String> = rest.iter().filter(|a| a.contains('=')).cloned().collect();
    let with_error = rest.iter().any(|a| a == "error");
    // and `smallest`: move the smallest interior object instead of the largest (the bench's
    // objects scenes).
    let smallest = rest.iter().any(|a| a == "smallest");
    // and `built`: before moving, still frames until a large scene's lazily built wall rows
    // are all ready (the moving frame once loading is over, not while it goes on).
    let built = rest.iter().any(|a| a == "built");
    // and `point`: a point light too, below the ceiling's middle (Step 1's punctual lights).
    let point = rest.iter().any(|a| a == "point");
    let mut scene = room(&RoomParams {
        objects,
        patches,
        big_object_patches: None,
    });
    // and `sky`: a uniform sky too (the room is closed: only its cost shows).
    if rest.iter().any(|a| a == "sky") {
        scene.environment = Some(shrad::scene::Environment::uniform(Vec3::new(0.3, 0.4, 0.6)));
    }
    if point {
        let b = scene.bounds().expect("a room");
        let at = Vec3::new(b.centre().x, b.min.y + 0.9 * b.size().y, b.centre().z);
        let mut light = Light::new("point", LightKind::Point, 2000.0);
        light.world_from_light = Affine3A::from_translation(at);
        scene.lights.push(light);
    }
    let t = std::time::Instant::now();
    let mut engine = Engine::new(
        scene,
        PatchSizing::Count(patches),
        Backend::Auto,
        SolverChoice::Dispersive(Default::default()),
    )
    .expect("engine");
    for kv in &settings {
        let (k, v) = kv.split_once('=').expect("key=value");
        engine.set_option(k, v).expect("a dispersive setting");
    }
    println!(
        "{} patches, set up in {:.2} s",
        engine.world().patches.len(),
        t.elapsed().as_secs_f64()
    );
    let p = &engine.world().patches;
    let interior = (0..p.object_role.len()).filter(|&o| p.object_role[o] == Role::Interior);
    let mover = match smallest {
        true => interior.min_by_key(|&o| p.range(o).len()),
        false => interior.max_by_key(|&o| p.range(o).len()),
    }
    .expect("an interior object");
    println!("mover: object {mover}, {} patches", p.range(mover).len());
    let t = std::time::Instant::now();
    let converged = engine.converge(2);
    let pending =
        (converged.last().and_then(|s| s.dispersive())).map_or(0, |d| d.wall_rows_pending);
    println!(
        "converged in {} frames, {:.1} s ({pending} wall rows still to build)",
        converged.len(),
        t.elapsed().as_secs_f64()
    );
    if built {
        let t = std::time::Instant::now();
        let mut frames = 0;
        while engine
            .step()
            .dispersive()
            .is_some_and(|d| d.wall_rows_pending > 0)
        {
            frames += 1;
        }
        println!(
            "wall rows built in {frames} more still frames, {:.1} s",
            t.elapsed().as_secs_f64()
        );
    }
    let rest = engine.transform(mover);
    let reach = 0.05 * engine.world().scene.bounds().unwrap().size().x;
    // Phase marks for `scripts/trace-table`, among the SHRAD_TRACE lines.
    eprintln!("# moving");
    let mut cpu_ms = Vec::new();
    let moving: Vec<FrameStats> = (1..=frames)
        .map(|k| {
            let cpu = cpu_ns();
            let phase = (k as f32 * std::f32::consts::TAU / 16.0).sin();
            engine
                .set_transform(
                    mover,
                    Affine3A::from_translation(Vec3::X * reach * phase) * rest,
                )
                .unwrap();
            let stats = match budget {
                Some(ms) => engine.step_within(ms).unwrap(),
                None => engine.step(),
            };
            cpu_ms.push((cpu_ns() - cpu) as f64 / 1e6);
            stats
        })
        .collect();
    eprintln!("# moved");
    report("moving", &moving);
    println!(
        "moving: CPU time a frame (all threads) {:.2} ms median",
        median(cpu_ms)
    );
    if with_error {
        let e = engine.error();
        println!(
            "error of the last moving frame: overall {:.3} %, boundary {:.3} %, interior {:.3} %",
            100.0 * e.overall,
            100.0 * e.boundary,
            100.0 * e.interior
        );
    }
    if let Some(ms) = budget {
        let mut t: Vec<f64> = moving.iter().map(|s| s.frame_ms).collect();
        t.sort_by(f64::total_cmp);
        let p95 = t[(t.len() * 95 / 100).min(t.len() - 1)];
        let stalest = moving.iter().map(|s| s.stalest).max().unwrap_or(0);
        println!(
            "budget {ms} ms: 95th percentile frame {p95:.2} ms ({:.2}x the budget), stalest {stalest} frames",
            p95 / ms as f64
        );
    }
    // The backend's rate on this scene: rays from random boundary patches in random
    // directions (closest hit), and shadow rays between random patch pairs.
    let world = engine.world();
    let n = world.patches.len();
    let mut h = 0x9e3779b9u32;
    let mut rnd = || {
        h ^= h << 13;
        h ^= h >> 17;
        h ^= h << 5;
        h
    };
    let m = 400_000;
    let origins: Vec<Vec3> = (0..m)
        .map(|_| world.patches.centre[rnd() as usize % n])
        .collect();
    let dirs: Vec<Vec3> = (0..m)
        .map(|_| {
            Vec3::new(rnd() as f32, rnd() as f32, rnd() as f32)
                .map(|x| x / u32::MAX as f32 - 0.5)
                .normalize_or(Vec3::X)
        })
        .collect();
    let mut hits = vec![shrad::vis::Hit::MISS; m];
    let t = std::time::Instant::now();
    world.vis.closest(&origins, &dirs, 1e-3, &[], &mut hits);
    let closest = m as f64 / t.elapsed().as_secs_f64() / 1e6;
    let to: Vec<Vec3> = (0..m)
        .map(|_| world.patches.centre[rnd() as usize % n])
        .collect();
    let mut blocked = vec![false; m];
    let t = std::time::Instant::now();
    world.vis.occluded(&origins, &to, 1e-3, &[], &mut blocked);
    let occluded = m as f64 / t.elapsed().as_secs_f64() / 1e6;
    // The same shadow rays against the mover alone (`occluded_among`, what Step 1 traces
    // first for the shadow rays a mover may have changed).
    let t = std::time::Instant::now();
    world
        .vis
        .occluded_among(&origins, &to, 1e-3, &[mover as u32], &mut blocked);
    let among = m as f64 / t.elapsed().as_secs_f64() / 1e6;
    println!("backend: {among:.1} Mrays/s occluded among the mover alone");
    let rays = median(moving.iter().map(|s| s.rays_cast as f64).collect());
    println!(
        "backend: {closest:.1} Mrays/s closest, {occluded:.1} Mrays/s occluded; the moving frame's rays at the closest rate: {:.2} ms",
        rays / closest / 1e3
    );
    // With a budget, the still frames are under it too.
    let mut still_frame = || match budget {
        Some(ms) => engine.step_within(ms).unwrap(),
        None => engine.step(),
    };
    let first: Vec<FrameStats> = (0..frames).map(|_| still_frame()).collect();
    report("still, first frames after", &first);
    let later: Vec<FrameStats> = (0..frames).map(|_| still_frame()).collect();
    report("still, later", &later);
    // The "a still frame without rays": the frames after the stop that ran (not
    // asleep) and traced nothing.
    let rayless: Vec<FrameStats> = (first.iter().chain(&later))
        .filter(|s| s.rays_cast == 0 && s.dispersive().is_some_and(|d| !d.asleep))
        .cloned()
        .collect();
    report(
        &format!("still, {} awake frames without rays", rayless.len()),
        &rayless,
    );
    let asleep_at =
        (first.iter().chain(&later)).position(|s| s.dispersive().is_some_and(|d| d.asleep));
    println!(
        "asleep after {} still frames",
        asleep_at.map_or("more than these".to_string(), |k| k.to_string())
    );
    if with_error {
        let e = engine.error();
        println!(
            "error once still: overall {:.3} %, boundary {:.3} %, interior {:.3} %",
            100.0 * e.overall,
            100.0 * e.boundary,
            100.0 * e.interior
        );
    }
    if let Some(ms) = budget {
        // The frames after the rest until the scene sleeps: the mover's full update, its
        // neighbours', the walls catching up, each under the budget.
        let mut awake: Vec<f64> = (first.iter().chain(&later))
            .filter(|s| s.dispersive().is_some_and(|d| !d.asleep))
            .map(|s| s.frame_ms)
            .collect();
        awake.sort_by(f64::total_cmp);
        let p95 = awake.get(awake.len() * 95 / 100).copied().unwrap_or(0.0);
        println!(
            "budget {ms} ms after the rest: {} frames awake, 95th percentile {p95:.2} ms ({:.2}x the budget), longest {:.2} ms, {} over 1.2x",
            awake.len(),
            p95 / ms as f64,
            awake.last().copied().unwrap_or(0.0),
            awake.iter().filter(|&&t| t > 1.2 * ms as f64).count()
        );
    }
}
