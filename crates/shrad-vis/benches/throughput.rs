//! Visibility throughput on a generated "room": a subdivided box room with a grid of
//! subdivided boxes and UV spheres inside (about 75k triangles, 82 objects). Per backend:
//! cube-map capture from 8 probes at 128² per face, random rays, shadow rays, and the cost
//! of set_transform + commit after one object moved.
//!
//! `SHRAD_BENCH_BIG=1` adds the same room at about 1M triangles.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Affine3A, Quat, Vec3};
use shrad_vis::{available_backends, build, Hit, MeshRef};

#[derive(Default)]
struct Mesh {
    p: Vec<Vec3>,
    t: Vec<[u32; 3]>,
    ids: Vec<u32>,
}

impl Mesh {
    fn r(&self) -> MeshRef<'_> {
        MeshRef {
            positions: &self.p,
            triangles: &self.t,
            ids: &self.ids,
            often_excluded: false,
        }
    }

    /// `n` x `n` grid of quads over the parallelogram `c + s u + t v`, s, t in [-1, 1],
    /// facing `u x v`.
    fn grid(&mut self, c: Vec3, u: Vec3, v: Vec3, n: u32, id: &mut u32) {
        let b = self.p.len() as u32;
        for j in 0..=n {
            for i in 0..=n {
                let (s, t) = (
                    i as f32 / n as f32 * 2.0 - 1.0,
                    j as f32 / n as f32 * 2.0 - 1.0,
                );
                self.p.push(c + u * s + v * t);
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = b + j * (n + 1) + i;
                let (b1, c1, d1) = (a + 1, a + n + 2, a + n + 1);
                self.t.push([a, b1, c1]);
                self.t.push([a, c1, d1]);
                self.ids.extend([*id, *id + 1]);
                *id += 2;
            }
        }
    }

    /// Axis box of half-size `h`, each face an `n` x `n` grid, facing out (or in).
    fn boxed(h: Vec3, n: u32, inward: bool, id: &mut u32) -> Mesh {
        let mut m = Mesh::default();
        let e = [Vec3::X, Vec3::Y, Vec3::Z];
        for a in 0..3 {
            for s in [1.0f32, -1.0] {
                let (mut u, mut v) = (e[(a + 1) % 3], e[(a + 2) % 3]);
                if (s < 0.0) != inward {
                    std::mem::swap(&mut u, &mut v);
                }
                m.grid(e[a] * s * h, u * h, v * h, n, id);
            }
        }
        m
    }

    fn sphere(r: f32, rings: u32, segs: u32, id: &mut u32) -> Mesh {
        let mut m = Mesh::default();
        for i in 0..=rings {
            let th = std::f32::consts::PI * i as f32 / rings as f32;
            for j in 0..segs {
                let ph = std::f32::consts::TAU * j as f32 / segs as f32;
                m.p.push(Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * r);
            }
        }
        for i in 0..rings {
            for j in 0..segs {
                let a = i * segs + j;
                let b = i * segs + (j + 1) % segs;
                if i != 0 {
                    m.t.push([a, a + segs, b]);
                    m.ids.push(*id);
                    *id += 1;
                }
                if i != rings - 1 {
                    m.t.push([b, a + segs, b + segs]);
                    m.ids.push(*id);
                    *id += 1;
                }
            }
        }
        m
    }
}

/// Room [-10, 10] x [0, 8] x [-10, 10] and a 9 x 9 grid of objects on the floor.
/// `detail` 1 gives ~75k triangles, 4 gives ~1M.
fn room(detail: u32) -> (Vec<Mesh>, Vec<Affine3A>) {
    let mut id = 0;
    let mut meshes = vec![Mesh::boxed(
        Vec3::new(10.0, 4.0, 10.0),
        32 * detail,
        true,
        &mut id,
    )];
    let mut xf = vec![Affine3A::from_translation(Vec3::new(0.0, 4.0, 0.0))];
    let mut k = 0u32;
    for gz in 0..9 {
        for gx in 0..9 {
            let m = if (gx + gz) % 2 == 0 {
                Mesh::boxed(Vec3::splat(0.6), 8 * detail, false, &mut id)
            } else {
                Mesh::sphere(0.7, 20 * detail, 20 * detail, &mut id)
            };
            meshes.push(m);
            k += 1;
            let q = Quat::from_euler(glam::EulerRot::YXZ, k as f32 * 0.7, k as f32 * 0.3, 0.0);
            let p = Vec3::new(
                gx as f32 * 2.0 - 8.0,
                1.0 + (k % 3) as f32 * 0.4,
                gz as f32 * 2.0 - 8.0,
            );
            xf.push(Affine3A::from_rotation_translation(q, p));
        }
    }
    (meshes, xf)
}

fn cube_dirs(res: usize) -> Vec<Vec3> {
    let mut d = Vec::with_capacity(6 * res * res);
    for face in 0..6 {
        for j in 0..res {
            for i in 0..res {
                let a = (i as f32 + 0.5) / res as f32 * 2.0 - 1.0;
                let c = (j as f32 + 0.5) / res as f32 * 2.0 - 1.0;
                let v = match face {
                    0 => Vec3::new(1.0, c, -a),
                    1 => Vec3::new(-1.0, c, a),
                    2 => Vec3::new(a, 1.0, -c),
                    3 => Vec3::new(a, -1.0, c),
                    4 => Vec3::new(a, c, 1.0),
                    _ => Vec3::new(-a, c, -1.0),
                };
                d.push(v.normalize());
            }
        }
    }
    d
}

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.f() * 2.0 - 1.0,
                self.f() * 2.0 - 1.0,
                self.f() * 2.0 - 1.0,
            );
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

fn machine() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    format!(
        "{model}, {cores} hardware threads, rayon {} threads",
        rayon::current_num_threads()
    )
}

/// CPU time (user + system) of this process so far, from /proc/self/stat (0 elsewhere).
fn cpu_secs() -> f64 {
    let Ok(s) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the ")" closing the command name: state is field 3; utime, stime are 14, 15.
    let rest = s.rsplit_once(')').map(|x| x.1).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| {
        f.get(i - 3)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(14) + ticks(15)) / 100.0
}

fn probes() -> Vec<Vec3> {
    (0..8)
        .map(|i| {
            Vec3::new(
                -7.0 + 2.0 * i as f32,
                3.5 + (i % 3) as f32,
                7.0 - 2.0 * i as f32,
            )
        })
        .collect()
}

fn bench_scene(c: &mut Criterion, label: &str, detail: u32) {
    let (meshes, xf) = room(detail);
    let refs: Vec<MeshRef<'_>> = meshes.iter().map(|m| m.r()).collect();
    let tris: usize = meshes.iter().map(|m| m.t.len()).sum();
    eprintln!(
        "[shrad-vis bench] {label}: {tris} triangles, {} objects; {}",
        meshes.len(),
        machine()
    );

    let dirs = cube_dirs(128);
    let points = probes();
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let n_rand = 1 << 18;
    let r_orig: Vec<Vec3> = (0..n_rand)
        .map(|_| {
            Vec3::new(
                rng.f() * 19.0 - 9.5,
                rng.f() * 7.5 + 0.25,
                rng.f() * 19.0 - 9.5,
            )
        })
        .collect();
    let r_dirs: Vec<Vec3> = (0..n_rand).map(|_| rng.dir()).collect();
    let s_to: Vec<Vec3> = (0..n_rand)
        .map(|_| {
            Vec3::new(
                rng.f() * 19.0 - 9.5,
                rng.f() * 7.5 + 0.25,
                rng.f() * 19.0 - 9.5,
            )
        })
        .collect();

    let mut reference: Option<Vec<Hit>> = None;
    for backend in available_backends() {
        let t0 = Instant::now();
        let mut vis = build(backend, &refs, &xf).expect("build");
        let build_time = t0.elapsed();
        let name = vis.name();

        // Sanity: from the room centre every ray hits something; backends agree.
        let mut cap = vec![Hit::MISS; points.len() * dirs.len()];
        let (t0, c0) = (Instant::now(), cpu_secs());
        vis.capture(&points, &dirs, 1e-4, &[], &mut cap);
        let once = t0.elapsed();
        let cpu = cpu_secs() - c0;
        assert!(
            cap.iter().all(|h| h.is_hit()),
            "{name}: a capture ray escaped the closed room"
        );
        if let Some(r) = &reference {
            // Different ids at the same distance are ties on shared edges (the grid room
            // and the symmetric cube directions make many); a real disagreement changes t.
            let ids = r.iter().zip(&cap).filter(|(a, b)| a.id != b.id).count();
            let diff = r
                .iter()
                .zip(&cap)
                .filter(|(a, b)| (a.t - b.t).abs() > 1e-3 * (1.0 + a.t))
                .count();
            eprintln!(
                "[shrad-vis bench] {name}: vs first backend, {ids} of {} capture rays differ in id, {diff} in distance",
                cap.len()
            );
            assert!(
                diff * 1000 <= cap.len(),
                "{name}: backends disagree on {diff} rays"
            );
        } else {
            reference = Some(cap.clone());
        }
        eprintln!(
            "[shrad-vis bench] {name}: build {:.1} ms; one capture pass {:.2} Mrays/s wall, {:.2} Mrays/s per CPU-second \
             (this process got {:.0}% of {} threads: other load on the machine lowers the wall figure)",
            build_time.as_secs_f64() * 1e3,
            cap.len() as f64 / once.as_secs_f64() / 1e6,
            cap.len() as f64 / cpu.max(1e-9) / 1e6,
            100.0 * cpu / once.as_secs_f64() / rayon::current_num_threads() as f64,
            rayon::current_num_threads()
        );

        let mut g = c.benchmark_group(format!("{label}/{name}"));
        g.sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        g.throughput(Throughput::Elements(cap.len() as u64));
        g.bench_function("capture_8x6x128x128", |b| {
            b.iter(|| vis.capture(black_box(&points), &dirs, 1e-4, &[], &mut cap));
        });
        let excl = [1u32];
        g.bench_function("capture_8x6x128x128_exclude1", |b| {
            b.iter(|| vis.capture(black_box(&points), &dirs, 1e-4, &excl, &mut cap));
        });
        // The same with object 1 flagged `often_excluded` (on Embree: a ray-mask bit of its
        // own among the 82 objects instead of the filter). Checked first: same hits.
        let flagged: Vec<MeshRef<'_>> = refs
            .iter()
            .enumerate()
            .map(|(o, m)| MeshRef {
                often_excluded: o == 1,
                ..*m
            })
            .collect();
        let vis_flagged = build(backend, &flagged, &xf).expect("build");
        let mut a = vec![Hit::MISS; cap.len()];
        vis.capture(&points, &dirs, 1e-4, &excl, &mut a);
        vis_flagged.capture(&points, &dirs, 1e-4, &excl, &mut cap);
        // (Ties on shared edges may pick either id; the distance must agree.)
        assert!(a
            .iter()
            .zip(&cap)
            .all(|(x, y)| (x.t - y.t).abs() <= 1e-3 * (1.0 + x.t) && y.object != 1));
        g.bench_function("capture_8x6x128x128_exclude1_flagged", |b| {
            b.iter(|| vis_flagged.capture(black_box(&points), &dirs, 1e-4, &excl, &mut cap));
        });
        let mut out = vec![Hit::MISS; n_rand];
        g.throughput(Throughput::Elements(n_rand as u64));
        g.bench_function("random_rays", |b| {
            b.iter(|| vis.closest(black_box(&r_orig), &r_dirs, 1e-4, &[], &mut out));
        });
        let mut occ = vec![false; n_rand];
        g.bench_function("shadow_rays", |b| {
            b.iter(|| vis.occluded(black_box(&r_orig), &s_to, 1e-4, &[], &mut occ));
        });
        g.throughput(Throughput::Elements(1));
        let mut k = 0u32;
        g.bench_function("move_one_object_commit", |b| {
            b.iter(|| {
                k += 1;
                let m = Affine3A::from_translation(Vec3::new(0.0, 0.01 * (k % 50) as f32, 0.0))
                    * xf[40];
                vis.set_transform(40, m);
                vis.commit();
            });
        });
        g.finish();
    }
}

fn benches(c: &mut Criterion) {
    bench_scene(c, "room75k", 1);
    if std::env::var("SHRAD_BENCH_BIG").is_ok_and(|v| v == "1") {
        bench_scene(c, "room1M", 4);
    }
}

criterion_group!(throughput, benches);
criterion_main!(throughput);
