//! Where the interior error is (issue 22 item 1; a diagnostic aid): the dispersive default,
//! converged, against the reference on the same patches, its interior error split by object,
//! by face orientation, by how close the patch is to other geometry, and into its direct and
//! reflected parts. Each row gives the share of the interior error's numerator
//! (`sum A |B - Bref|^2`), the row's own relative error and its bias (`sum A (B - Bref) /
//! sum A Bref`, mean of the three channels).
//!
//! `cargo run --release --example interior_errors -- SCENE [patches] [key=value ...]`
//! (SCENE: a scene file or a built-in name, `cornell`, `room`; the keys are `--set`'s). The
//! reference (128 rays a patch, 32 direct samples, the bench's) is kept in
//! `$TMPDIR/shrad-reference-*.bin` for the next run on the same scene and patch count.
use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec3;
use shrad::dispersive::{Dispersive, DispersiveOptions};
use shrad::metrics::relative_error;
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::Role;
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

/// One row of the breakdown: sums over its patches.
#[derive(Default, Clone, Copy)]
struct Sums {
    area: f64,
    num: f64,
    den: f64,
    diff: f64,
    reference: f64,
    /// `sum A |rho (E_direct - E_direct,ref)|^2` (the light surfaces' direct light; NaN when
    /// the solver keeps none per interior patch): the part of `num` the direct light alone
    /// would give.
    direct_num: f64,
}

impl Sums {
    fn add(&mut self, a: f64, b: Vec3, r: Vec3, direct_diff: Vec3) {
        self.area += a;
        self.num += a * (b - r).length_squared() as f64;
        self.den += a * r.length_squared() as f64;
        self.diff += a * (b - r).element_sum() as f64;
        self.reference += a * r.element_sum() as f64;
        self.direct_num += a * direct_diff.length_squared() as f64;
    }
}

fn load_world(name: &str, patches: usize) -> World {
    // `room-N`: the bench's room with N objects (`objects-N` scenes at 40k patches).
    if let Some(objects) = name.strip_prefix("room-").and_then(|n| n.parse().ok()) {
        let scene = shrad::scene::room(&shrad::scene::RoomParams {
            objects,
            patches,
            big_object_patches: None,
        });
        return World::new(scene, PatchSizing::Count(patches), Backend::Auto).expect("world");
    }
    let mut scene = if shrad::scene::builtin_names().contains(&name) {
        let mut s = shrad::scene::builtin(name).expect("built-in scene");
        if name == "room" {
            // The bench's room: 8 objects (`RoomParams`' default).
            s = shrad::scene::room(&shrad::scene::RoomParams {
                objects: 8,
                patches,
                big_object_patches: None,
            });
        }
        s
    } else {
        shrad::scene::load(Path::new(name), &Default::default()).unwrap_or_else(|e| panic!("{e}"))
    };
    shrad::scene::infer_roles(&mut scene);
    World::new(scene, PatchSizing::Count(patches), Backend::Auto).expect("world")
}

/// The reference radiosity, from the cache file when it holds one of this many patches.
fn reference(world: &World, name: &str, patches: usize) -> Vec<Vec3> {
    let stem = Path::new(name).file_stem().unwrap().to_string_lossy();
    let path = std::env::temp_dir().join(format!(
        "shrad-reference-{stem}-{patches}-{}.bin",
        world.patches.len()
    ));
    if let Ok(bytes) = std::fs::read(&path) {
        let v: Vec<Vec3> = bytes
            .chunks_exact(12)
            .map(|c| {
                let f = |k: usize| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap());
                Vec3::new(f(0), f(1), f(2))
            })
            .collect();
        if v.len() == world.patches.len() {
            return v;
        }
    }
    let options = ReferenceOptions {
        rays_per_patch: 128,
        direct_samples: 32,
        ..ReferenceOptions::standard()
    };
    let (r, _) = solve(world, &options, &NoProgress);
    let bytes: Vec<u8> = r
        .iter()
        .flat_map(|v| v.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let _ = std::fs::write(&path, bytes);
    r
}

/// Per interior patch, the fraction of 16 cosine-distributed rays that hit something within
/// `reach` (other objects and the walls; not the patch's own object).
fn closeness(world: &World, reach_of: impl Fn(usize) -> f32) -> Vec<f32> {
    let p = &world.patches;
    const RAYS: u32 = 16;
    let mut out = vec![0.0; p.len()];
    for (o, role) in p.object_role.iter().enumerate() {
        if *role != Role::Interior {
            continue;
        }
        let reach = reach_of(o);
        let (mut from, mut to) = (Vec::new(), Vec::new());
        for i in p.range(o) {
            let n = p.normal[i];
            let start = p.centre[i] + n * world.eps;
            for j in 0..RAYS {
                let (u, v) = shrad::sampling::hammersley(j, RAYS, (0.37, 0.5));
                let d = shrad::sampling::square_to_cosine_hemisphere(u, v, n);
                from.push(start);
                to.push(start + d * reach);
            }
        }
        let mut blocked = vec![false; from.len()];
        world
            .vis
            .occluded(&from, &to, world.eps, &[o as u32], &mut blocked);
        for (i, b) in p.range(o).zip(blocked.chunks(RAYS as usize)) {
            out[i] = b.iter().filter(|&&b| b).count() as f32 / RAYS as f32;
        }
    }
    out
}

fn print_rows(title: &str, rows: &BTreeMap<String, Sums>, total_num: f64) {
    println!("\n{title}");
    println!(
        "  {:<28} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "", "area %", "share %", "error %", "bias %", "direct%"
    );
    let area: f64 = rows.values().map(|s| s.area).sum();
    // Relative to the whole table's mean: a row the reference leaves dark (faces resting on
    // the floor) has no relative error worth printing ("-"), only its share.
    let mean_reference = rows.values().map(|s| s.reference).sum::<f64>() / area.max(1e-30);
    for (name, s) in rows {
        let dark = s.reference <= 1e-6 * mean_reference * s.area;
        let percent = |x: f64| match dark {
            true => format!("{:>8}", "-"),
            false => format!("{:>8.2}", 100.0 * x),
        };
        let direct = match s.direct_num.is_nan() {
            true => format!("{:>8}", "-"),
            false => format!("{:>8.1}", 100.0 * s.direct_num / s.num.max(1e-30)),
        };
        println!(
            "  {:<28} {:>8.1} {:>8.1} {} {} {}",
            name,
            100.0 * s.area / area,
            100.0 * s.num / total_num,
            percent((s.num / s.den.max(1e-30)).sqrt()),
            percent(s.diff / s.reference.max(1e-30)),
            direct,
        );
    }
}

fn options_from(pairs: &[String]) -> DispersiveOptions {
    let mut choice = SolverChoice::preset("dispersive", "default").unwrap();
    for kv in pairs {
        let (k, v) = kv.split_once('=').expect("key=value");
        choice.set(k, v).unwrap_or_else(|e| panic!("{e}"));
    }
    match choice {
        SolverChoice::Dispersive(o) => o,
        _ => unreachable!(),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args
        .first()
        .expect("usage: interior_errors SCENE [patches] [key=value ...]");
    let patches: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let pairs: Vec<String> = args.iter().filter(|a| a.contains('=')).cloned().collect();
    let options = options_from(&pairs);
    let world = load_world(name, patches);
    let reference = reference(&world, name, patches);
    let t = std::time::Instant::now();
    let mut d = Dispersive::new(&world, options).unwrap();
    let setup = t.elapsed().as_secs_f64();
    d.converge(&world, 8);
    let b = d.radiosity();
    let e = relative_error(&world.patches, b, &reference);
    println!(
        "{name}: {} patches, setup {setup:.1} s; overall / boundary / interior {:.2} / {:.2} / {:.2} %",
        world.patches.len(),
        100.0 * e.overall,
        100.0 * e.boundary,
        100.0 * e.interior
    );
    breakdown(&world, &d, &reference);
    print_probes(&world, &d, &reference);
    print_worst(&world, &d, &reference);
    print_around(&world, &d, &reference);
}

/// With `AROUND=x,y,z,r`, every patch whose centre lies within r of (x, y, z).
fn print_around(world: &World, d: &Dispersive, reference: &[Vec3]) {
    let Ok(spec) = std::env::var("AROUND") else {
        return;
    };
    let v: Vec<f32> = spec.split(',').filter_map(|x| x.parse().ok()).collect();
    let (at, r) = (Vec3::new(v[0], v[1], v[2]), v[3]);
    let p = &world.patches;
    for i in (0..p.len()).filter(|&i| p.centre[i].distance(at) <= r) {
        println!(
            "around: patch {i} {} at {:.3?} n {:.2?}: disp {:.4?} ref {:.4?}",
            world.scene.objects[p.object[i] as usize].name,
            p.centre[i],
            p.normal[i],
            d.radiosity()[i],
            reference[i]
        );
    }
}

/// With `WORST=n`, the n interior patches with the largest share of the (interior) error.
fn print_worst(world: &World, d: &Dispersive, reference: &[Vec3]) {
    let Some(n) = std::env::var("WORST")
        .ok()
        .and_then(|s| s.parse::<usize>().ok())
    else {
        return;
    };
    let p = &world.patches;
    let b = d.radiosity();
    // `WORST_ROLE=boundary`: the boundary's patches instead.
    let role = match std::env::var("WORST_ROLE").as_deref() {
        Ok("boundary") => Role::Boundary,
        _ => Role::Interior,
    };
    let mut rows: Vec<(f64, usize)> = (0..p.len())
        .filter(|&i| p.role(i) == role)
        .map(|i| {
            (
                p.area[i] as f64 * (b[i] - reference[i]).length_squared() as f64,
                i,
            )
        })
        .collect();
    let total: f64 = rows.iter().map(|r| r.0).sum();
    rows.sort_by(|a, b| b.0.total_cmp(&a.0));
    rows.truncate(n);
    // Each patch's direct light, the dispersive solver's and a 64-sample one, red channel.
    let ids: Vec<u32> = rows.iter().map(|r| r.1 as u32).collect();
    let ref_direct = shrad::direct::direct_irradiance(world, &ids, 64);
    let direct = d.direct_irradiance();
    for (&(num, i), rd) in rows.iter().zip(&ref_direct) {
        println!(
            "{:5.2} % patch {i} {} at {:.3?} n {:.2?}: disp {:.4?} ref {:.4?}; direct E.r {:.4} / {:.4}",
            100.0 * num / total,
            world.scene.objects[p.object[i] as usize].name,
            p.centre[i],
            p.normal[i],
            b[i],
            reference[i],
            direct.map_or(f32::NAN, |e| e[i].x),
            rd.x,
        );
    }
}

fn breakdown(world: &World, d: &Dispersive, reference: &[Vec3]) {
    let p = &world.patches;
    let b = d.radiosity();
    let all: Vec<u32> = (0..p.len() as u32).collect();
    let ref_direct = shrad::direct::direct_irradiance(world, &all, 64);
    // The light surfaces' direct light, the solver's against a 64-sample one: the solver's
    // `direct` holds the punctual lights' too, which `ref_direct` leaves out (a courtyard's
    // sun made the column read millions of per cent); without `direct_on_interior` there is
    // no per-patch direct light to compare ("-").
    let direct = d.direct_irradiance();
    let punctual = d.punctual_irradiance();
    let diagonal = |o: usize| {
        let b = world.scene.objects[o].world_bounds().unwrap();
        (b.max - b.min).length()
    };
    let near = closeness(world, |o| 0.1 * diagonal(o));
    let (mut by_object, mut by_face, mut by_near) =
        (BTreeMap::new(), BTreeMap::new(), BTreeMap::new());
    let (mut by_side, mut by_height) = (BTreeMap::new(), BTreeMap::new());
    let mut total = Sums::default();
    for i in 0..p.len() {
        if p.role(i) != Role::Interior {
            continue;
        }
        let o = p.object[i] as usize;
        let a = p.area[i] as f64;
        let dd = match direct {
            Some(e) => {
                let area_lights = e[i] - punctual.get(i).copied().unwrap_or(Vec3::ZERO);
                world.reflectance[i] * (area_lights - ref_direct[i])
            }
            None => Vec3::NAN,
        };
        let n = p.normal[i];
        let face = if n.y > 0.7 {
            "up"
        } else if n.y < -0.7 {
            "down"
        } else {
            "side"
        };
        let near_name = match near[i] {
            0.0 => "a: nothing within 0.1 diag",
            x if x < 0.26 => "b: <= 1/4 blocked",
            x if x < 0.76 => "c: 1/4..3/4 blocked",
            _ => "d: > 3/4 blocked",
        };
        let object = format!("{:>3} {}", o, world.scene.objects[o].name);
        let bounds = world.scene.objects[o].world_bounds().unwrap();
        let h = (p.centre[i].y - bounds.min.y) / (bounds.max.y - bounds.min.y).max(1e-6);
        let ln = p.normal_local[i];
        let axis = ln.abs().max_position();
        let side = format!(
            "{object} {}{}",
            if ln[axis] > 0.0 { '+' } else { '-' },
            ['x', 'y', 'z'][axis]
        );
        let height = format!("{face} height {:.1}", (h * 5.0).floor().min(4.0) / 5.0);
        for (map, key) in [
            (&mut by_side, side),
            (&mut by_height, height),
            (&mut by_object, object),
            (&mut by_face, face.to_string()),
            (&mut by_near, near_name.to_string()),
        ] {
            map.entry(key)
                .or_insert_with(Sums::default)
                .add(a, b[i], reference[i], dd);
        }
        total.add(a, b[i], reference[i], dd);
    }
    print_rows("by object", &by_object, total.num);
    print_rows("by face (world normal)", &by_face, total.num);
    print_rows("by object and face (local normal)", &by_side, total.num);
    print_rows(
        "by face and height in the object's box",
        &by_height,
        total.num,
    );
    print_rows(
        "by closeness (rays within 0.1 of the object's diagonal)",
        &by_near,
        total.num,
    );
    print_rows(
        "all interior",
        &BTreeMap::from([("all".to_string(), total)]),
        total.num,
    );
}

/// With `PROBES=object`, the probes of that object: where they stand, their state and the
/// mean radiance they see (SH band 0).
fn print_probes(world: &World, d: &Dispersive, reference: &[Vec3]) {
    let Ok(name) = std::env::var("PROBES") else {
        return;
    };
    for v in d.probe_views(world) {
        if world.scene.objects[v.object].name != name {
            continue;
        }
        let dc = v.sh.coeffs()[0];
        println!(
            "probe {} at {:.3?}: {:?}, band 0 {:.4?}",
            v.corner, v.position, v.state, dc
        );
    }
    let o = world
        .scene
        .objects
        .iter()
        .position(|x| x.name == name)
        .unwrap();
    let p = &world.patches;
    for i in p.range(o).step_by(7) {
        println!(
            "patch {i} at {:.3?} n {:.2?}: disp {:.4?} ref {:.4?}",
            p.centre[i],
            p.normal[i],
            d.radiosity()[i],
            reference[i]
        );
    }
}
