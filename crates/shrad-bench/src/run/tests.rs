use super::*;
use crate::moving::moving_frames;

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
    let mut objects = SceneSpec::tiny(Table::Objects, 3, 1500);
    objects.name = "tiny-objects".into();
    let mut options = BenchOptions::new(true);
    options.scenes = vec![SceneSpec::tiny(Table::Scaling, 2, 1500), objects];
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

/// Through `run_solver`: the moved reference is of a moved state (not of the rest the
/// object goes back to) and two solvers whose windows end at the same place share it.
#[test]
fn run_solver_measures_the_error_while_moving() {
    let spec = SceneSpec::tiny(Table::Scaling, 2, 1200);
    let world = build_world(&spec, Backend::Auto).unwrap();
    let mut options = BenchOptions::new(true);
    options.reference = ReferenceOptions::fast();
    let (reference, _) = solve(&world, &options.reference, &NoProgress);
    let mut scene = SceneRun::new(&spec, &reference, 0.0);
    scene.ray_rate = crate::rays::measure_ray_rate(&world, 20_000, 4_096);
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
    let spec = SceneSpec::tiny(Table::Scaling, 2, 1200);
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
