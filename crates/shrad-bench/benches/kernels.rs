//! Micro-benchmarks of the kernels of a frame: cube-map capture, SH projection, per-patch
//! interpolation and shading, the boundary splat, and whole dispersive / grid frames on a
//! small room.
//! Every benchmark checks its result once before it is timed. Run:
//! `cargo bench -p shrad-bench --bench kernels -- --measurement-time 3 --warm-up-time 1`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use shrad::dispersive::splat_to_boundary;
use shrad::engine::Engine;
use shrad::probes::ProbeCamera;
use shrad::scene::{room, Role, RoomParams};
use shrad::vis::{Backend, Hit};
use shrad::{PatchSizing, World};
use shrad_bench::{check_radiosity, Machine, SolverKind};
use shrad_sh::{cosine_lobe_sh, num_coeffs, trilinear_weights, CubeMap, ShProjector, ShRgb};

fn small_room(patches: usize) -> World {
    let scene = room(&RoomParams {
        objects: 8,
        patches,
        big_object_patches: None,
    });
    World::new(scene, PatchSizing::Count(patches), Backend::Auto).expect("room builds")
}

/// The 8 corners of the world bounds of the first interior object.
fn corners_of_first_object(world: &World) -> Vec<Vec3> {
    let p = &world.patches;
    let o = (0..p.object_role.len())
        .find(|&o| p.object_role[o] == Role::Interior)
        .expect("an interior object");
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for i in p.range(o) {
        lo = lo.min(p.centre[i]);
        hi = hi.max(p.centre[i]);
    }
    let pad = 0.01 * (hi - lo).length();
    // Keep the probes above the floor (objects stand on it): below it rays escape.
    let (lo, hi) = (
        (lo - pad).max(Vec3::new(f32::MIN, 0.05, f32::MIN)),
        hi + pad,
    );
    (0..8)
        .map(|c| {
            let s = Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
            lo + (hi - lo) * s
        })
        .collect()
}

fn capture(c: &mut Criterion) {
    let world = small_room(20_000);
    eprintln!("machine: {}", Machine::detect(world.vis.name()).line());
    let points = corners_of_first_object(&world);
    let own = (0..world.patches.object_role.len())
        .find(|&o| world.patches.object_role[o] == Role::Interior)
        .expect("an interior object") as u32;
    let mut g = c.benchmark_group("capture");
    // The paper's probes (R = 128, own texels black) and the default's (R = 32, the object
    // transparent).
    for (res, exclude) in [(128, vec![]), (32, vec![own])] {
        let cube = CubeMap::new(res);
        let n = points.len() * cube.directions.len();
        let mut hits = vec![Hit::MISS; n];
        // Check: a closed room, every ray from inside hits something, never the excluded.
        world
            .vis
            .capture(&points, &cube.directions, 0.0, &exclude, &mut hits);
        let missed = hits.iter().filter(|h| !h.is_hit()).count();
        assert!(
            missed * 1000 < n,
            "{missed} of {n} rays missed in a closed room"
        );
        assert!(hits.iter().all(|h| !exclude.contains(&h.object)));
        g.throughput(Throughput::Elements(n as u64));
        let name = if exclude.is_empty() {
            format!("8 probes R={res} (rays), room 20k")
        } else {
            format!("8 probes R={res}, own object excluded (rays), room 20k")
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                world.vis.capture(
                    black_box(&points),
                    &cube.directions,
                    0.0,
                    &exclude,
                    &mut hits,
                );
                black_box(hits[0].id)
            })
        });
    }
    g.finish();
}

fn projection(c: &mut Criterion) {
    let cube = CubeMap::new(128);
    let projector = ShProjector::new(4, &cube);
    // Check: constant radiance 1 projects to c0 = 4 pi Y00 = 2 sqrt(pi), the rest ~0.
    let ones = vec![Vec3::ONE; cube.directions.len()];
    let sh = projector.project(&ones);
    let c0 = sh.coeffs()[0].x;
    assert!(
        (c0 - 2.0 * std::f32::consts::PI.sqrt()).abs() < 1e-3,
        "c0 = {c0}"
    );
    assert!(sh.coeffs()[1..]
        .iter()
        .all(|v| v.abs().max_element() < 1e-3));
    assert_eq!(sh.coeffs().len(), 16);
    let radiance: Vec<Vec3> = cube
        .directions
        .iter()
        .map(|d| Vec3::new(d.x.max(0.0), d.y * d.y, 1.0 + d.z))
        .collect();
    let mut g = c.benchmark_group("sh_projection");
    g.throughput(Throughput::Elements(radiance.len() as u64));
    g.bench_function("R=128, 16 coeffs, RGB (texels)", |b| {
        b.iter(|| black_box(projector.project(black_box(&radiance))))
    });
    // As a probe projects: each texel's radiance looked up by the id of what it sees.
    let palette: Vec<Vec3> = (0..1000).map(|i| Vec3::splat(i as f32)).collect();
    let ids: Vec<usize> = (0..radiance.len()).map(|t| (t * 7919) % 1000).collect();
    let mut out = ShRgb::zeros(4);
    g.bench_function("R=128, 16 coeffs, RGB (palette by texel id)", |b| {
        b.iter(|| {
            projector.project_with_into(|t| palette[ids[t]], &mut out);
            black_box(&out);
        })
    });
    g.finish();
}

fn interpolation(c: &mut Criterion) {
    // The loop of dispersive.rs light_selected_objects (Step 2 after the capture), over the
    // patches of the largest object of the 77k room, one thread.
    let world = small_room(77_000);
    let p = &world.patches;
    let o = (0..p.object_role.len())
        .filter(|&o| p.object_role[o] == Role::Interior)
        .max_by_key(|&o| p.range(o).len())
        .expect("an interior object");
    let range = p.range(o);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for i in range.clone() {
        lo = lo.min(p.centre_local[i]);
        hi = hi.max(p.centre_local[i]);
    }
    let weights: Vec<[f32; 8]> = range
        .clone()
        .map(|i| {
            trilinear_weights(((p.centre_local[i] - lo) / (hi - lo)).clamp(Vec3::ZERO, Vec3::ONE))
        })
        .collect();
    let bands = 4;
    let nc = num_coeffs(bands);
    // Probes: uniform radiance k (DC only) plus a little of band 1.
    let probes: Vec<ShRgb> = (0..8)
        .map(|k| {
            let mut c = vec![Vec3::ZERO; nc];
            c[0] = Vec3::splat(1.0 + k as f32 * 0.1);
            c[2] = Vec3::splat(0.05);
            ShRgb::from_coeffs(c)
        })
        .collect();
    let refs: [&ShRgb; 8] = std::array::from_fn(|c| &probes[c]);
    let shade = |out: &mut Vec<Vec3>| {
        out.clear();
        for i in range.clone() {
            let w = &weights[i - range.start];
            let l = ShRgb::lerp8(&refs, w);
            let mut lobe = [0f32; 64];
            cosine_lobe_sh(bands, p.normal[i], &mut lobe[..nc]);
            out.push(l.dot(&lobe[..nc]).max(Vec3::ZERO));
        }
    };
    // Check: uniform radiance L gives irradiance pi L; here L is in [1, 1.7] / Y00 scaled.
    let mut out = Vec::with_capacity(range.len());
    shade(&mut out);
    assert!(out
        .iter()
        .all(|e| e.is_finite() && e.min_element() > 0.0 && e.max_element() < 10.0));
    let mut g = c.benchmark_group("interpolate_shade");
    g.throughput(Throughput::Elements(range.len() as u64));
    g.bench_function(
        format!("lerp8 + cosine lobe dot, {} patches (patches)", range.len()),
        |b| {
            b.iter(|| {
                shade(&mut out);
                black_box(out.len())
            })
        },
    );
    g.finish();
}

fn splat(c: &mut Criterion) {
    // Step 3 from one emitter: the first interior object's reflected light as a cosine lobe
    // pointing up from its box centre, splatted with a 64^2 cube map onto the 77k room's
    // boundary (the default's resolution), the object itself transparent.
    let world = small_room(77_000);
    let p = &world.patches;
    let o = (0..p.object_role.len())
        .find(|&o| p.object_role[o] == Role::Interior)
        .expect("an interior object");
    let corners = corners_of_first_object(&world);
    let centre = corners.iter().copied().sum::<Vec3>() / 8.0;
    let bands = 4;
    let nc = num_coeffs(bands);
    let mut lobe = [0f32; 64];
    cosine_lobe_sh(bands, Vec3::Y, &mut lobe[..nc]);
    // Intensity I(w) = max(0, cos) W/sr (SH of the clamped cosine / pi): 1 W in total.
    let intensity = ShRgb::from_coeffs(
        lobe[..nc]
            .iter()
            .map(|&c| Vec3::splat(c / std::f32::consts::PI))
            .collect(),
    );
    let camera = ProbeCamera::new(64, bands);
    // Check: the room is closed, so the flux lands on the boundary or on other objects;
    // the emitter sends 1 W upwards and most of it reaches the ceiling and walls.
    let pieces = splat_to_boundary(&world, &camera, o as u32, centre, &intensity);
    let landed: f32 = pieces.iter().map(|e| e.1.x).sum();
    assert!(
        (0.7..=1.02).contains(&landed),
        "splat landed {landed} W of 1 W on the boundary"
    );
    let rays = (0..camera.texels())
        .filter(|&t| camera.projector.texel_value(&intensity, t).x > 0.0)
        .count();
    let mut g = c.benchmark_group("splat");
    g.throughput(Throughput::Elements(rays as u64));
    g.bench_function(
        format!("one emitter, 64^2, room 77k, {rays} texels traced (rays)"),
        |b| {
            b.iter(|| {
                black_box(splat_to_boundary(&world, &camera, o as u32, centre, &intensity).len())
            })
        },
    );
    g.finish();
}

fn frames(c: &mut Criterion) {
    let mut world = small_room(12_000);
    let n = world.patches.len() as u64;
    let mut g = c.benchmark_group("frame");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    let kinds = [
        (
            "dispersive default, room 12k (patches)",
            SolverKind::Dispersive,
        ),
        ("dispersive paper, room 12k (patches)", SolverKind::Paper),
        ("grid G=4, room 12k (patches)", SolverKind::Grid4),
    ];
    for (name, kind) in kinds {
        // The engine a front end drives, on the same world for each solver.
        let mut engine = Engine::from_world(world, kind.choice()).expect("a preset is valid");
        for _ in 0..engine.frames_to_converge(1) {
            let _ = engine.step();
        }
        check_radiosity(engine.world(), engine.radiosity()).expect("radiosity is sane");
        g.bench_function(name, |b| b.iter(|| black_box(engine.step().frame_ms)));
        world = engine.into_world();
    }
    g.finish();
}

criterion_group! {
    name = kernels;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    targets = capture, projection, interpolation, splat, frames
}
criterion_main!(kernels);
