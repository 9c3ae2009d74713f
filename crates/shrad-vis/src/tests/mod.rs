//! One test body per property, run over every backend in this build, checked against exact
//! answers or a brute-force f64 reference.
//!
//! Here the scenes and the reference; `exact`: answers known in closed form (boxes, quads,
//! exclusion, occlusion, degenerate input, backend choice); `against_reference`: random rays,
//! captures, moving objects and a closed room against the f64 brute force.

mod against_reference;
mod exact;

use glam::{Affine3A, DVec3, Quat, Vec3};

use crate::{available_backends, build, Backend, Hit, MeshRef, VisError, Visibility, NO_HIT};

/// Triangle soup of one object.
#[derive(Clone, Default)]
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

    /// Counter-clockwise quad `p0..p3`, two triangles, ids `id, id + 1`.
    fn quad(&mut self, q: [Vec3; 4], id: u32) {
        let b = self.p.len() as u32;
        self.p.extend_from_slice(&q);
        self.t.push([b, b + 1, b + 2]);
        self.t.push([b, b + 2, b + 3]);
        self.ids.extend_from_slice(&[id, id + 1]);
    }
}

/// Unit box `[-0.5, 0.5]^3`, outward faces. Face `f` (0..6 = +x, -x, +y, -y, +z, -z) has
/// ids `base + 10 f` and `base + 10 f + 1`.
fn cube(base: u32) -> Mesh {
    let mut m = Mesh::default();
    let e = [Vec3::X, Vec3::Y, Vec3::Z];
    for a in 0..3 {
        for (si, s) in [1.0f32, -1.0].into_iter().enumerate() {
            let n = e[a] * s;
            let (u, v) = if s > 0.0 {
                (e[(a + 1) % 3], e[(a + 2) % 3])
            } else {
                (e[(a + 2) % 3], e[(a + 1) % 3])
            };
            let c = n * 0.5;
            let (u, v) = (u * 0.5, v * 0.5);
            let f = (2 * a + si) as u32;
            m.quad([c - u - v, c + u - v, c + u + v, c - u + v], base + 10 * f);
        }
    }
    m
}

/// UV sphere of radius 1, outward.
fn sphere(rings: u32, segs: u32, base: u32) -> Mesh {
    let mut m = Mesh::default();
    for i in 0..=rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segs {
            let ph = std::f32::consts::TAU * j as f32 / segs as f32;
            m.p.push(Vec3::new(
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
            ));
        }
    }
    let mut id = base;
    for i in 0..rings {
        for j in 0..segs {
            let a = i * segs + j;
            let b = i * segs + (j + 1) % segs;
            let (c, d) = (a + segs, b + segs);
            // Outward: from +z pole downwards, (a, c, d) is counter-clockwise seen from outside.
            if i != 0 {
                m.t.push([a, c, b]);
                m.ids.push(id);
                id += 1;
            }
            if i != rings - 1 {
                m.t.push([b, c, d]);
                m.ids.push(id);
                id += 1;
            }
        }
    }
    m
}

fn backends() -> Vec<Backend> {
    let b = available_backends();
    assert!(b.contains(&Backend::Bvh));
    b
}

fn make(b: Backend, meshes: &[Mesh], xf: &[Affine3A]) -> Box<dyn Visibility> {
    let refs: Vec<MeshRef<'_>> = meshes.iter().map(|m| m.r()).collect();
    build(b, &refs, xf).unwrap()
}

fn one(v: &dyn Visibility, o: Vec3, d: Vec3, exclude: &[u32]) -> Hit {
    let mut out = [Hit::MISS];
    v.closest(&[o], &[d.normalize()], 0.0, exclude, &mut out);
    out[0]
}

fn cube_dirs(res: usize) -> Vec<Vec3> {
    let mut d = Vec::new();
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

/// A random-ish scene: a few boxes and spheres, rotated and scaled uniformly.
fn random_scene(seed: u64, n: usize) -> (Vec<Mesh>, Vec<Affine3A>) {
    let mut rng = Rng(seed);
    let mut meshes = Vec::new();
    let mut xf = Vec::new();
    for i in 0..n {
        let m = if i % 2 == 0 {
            cube(i as u32 * 10_000)
        } else {
            sphere(6 + (i % 5) as u32, 12, i as u32 * 10_000)
        };
        meshes.push(m);
        let q = Quat::from_euler(
            glam::EulerRot::XYZ,
            rng.f() * 6.0,
            rng.f() * 6.0,
            rng.f() * 6.0,
        );
        let s = 0.3 + rng.f() * 1.2;
        let t = Vec3::new(
            rng.f() * 8.0 - 4.0,
            rng.f() * 8.0 - 4.0,
            rng.f() * 8.0 - 4.0,
        );
        xf.push(Affine3A::from_scale_rotation_translation(
            Vec3::splat(s),
            q,
            t,
        ));
    }
    (meshes, xf)
}

/// `n` rays from points uniform in the cube `[-half, half]^3`, in uniform directions.
fn random_rays(rng: &mut Rng, n: usize, half: f32) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut c = || rng.f() * 2.0 * half - half;
    let origins: Vec<Vec3> = (0..n).map(|_| Vec3::new(c(), c(), c())).collect();
    let dirs = (0..n).map(|_| rng.dir()).collect();
    (origins, dirs)
}

struct Rng(u64);
impl Rng {
    fn u(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn f(&mut self) -> f32 {
        (self.u() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.f() * 2.0 - 1.0,
                self.f() * 2.0 - 1.0,
                self.f() * 2.0 - 1.0,
            );
            let l = v.length_squared();
            if l > 1e-3 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// Brute force in f64: (t, object, id, front) of every triangle hit, nearest first.
fn reference(
    meshes: &[Mesh],
    xf: &[Affine3A],
    o: Vec3,
    d: Vec3,
    t_min: f64,
    exclude: &[u32],
) -> Vec<(f64, u32, u32, bool)> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let mut hits = Vec::new();
    for (obj, m) in meshes.iter().enumerate() {
        if exclude.contains(&(obj as u32)) {
            continue;
        }
        for (tri, id) in m.t.iter().zip(&m.ids) {
            let [a, b, c] = tri.map(|i| xf[obj].transform_point3(m.p[i as usize]).as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-300 {
                continue;
            }
            let s = o - a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= t_min {
                let n: DVec3 = e1.cross(e2);
                hits.push((t, obj as u32, *id, d.dot(n) < 0.0));
            }
        }
    }
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    hits
}

/// Check a backend hit against the reference; returns false on a tolerated near-tie /
/// edge case (counted by the caller), panics on a real disagreement.
fn agrees(h: &Hit, r: &[(f64, u32, u32, bool)], what: &str) -> bool {
    let tol = 1e-4;
    match r.first() {
        None => {
            assert!(!h.is_hit(), "{what}: backend hit {h:?}, reference misses");
            true
        }
        Some(&(t, obj, id, front)) => {
            if !h.is_hit() {
                // A ray through a shared edge / vertex may slip through in single precision.
                return false;
            }
            assert!(
                (h.t as f64 - t).abs() < tol * (1.0 + t),
                "{what}: t {h:?} vs {t}"
            );
            if h.id == id && h.object == obj {
                assert_eq!(h.front, front, "{what}: front {h:?}");
                true
            } else {
                // Must be a near-tie: the backend's triangle is also hit at about the same t.
                assert!(
                    r.iter().any(|&(t2, o2, i2, _)| o2 == h.object
                        && i2 == h.id
                        && (t2 - t).abs() < tol * (1.0 + t)),
                    "{what}: {h:?} vs reference {:?}",
                    &r[..r.len().min(3)]
                );
                false
            }
        }
    }
}

/// Inward-facing box room, each face an `n` x `n` grid of quads.
fn room(h: Vec3, n: u32) -> Mesh {
    let mut m = Mesh::default();
    let e = [Vec3::X, Vec3::Y, Vec3::Z];
    let mut id = 0;
    for a in 0..3 {
        for s in [1.0f32, -1.0] {
            let (mut u, mut v) = (e[(a + 1) % 3] * h, e[(a + 2) % 3] * h);
            if s > 0.0 {
                std::mem::swap(&mut u, &mut v);
            }
            let c = e[a] * s * h;
            for j in 0..n {
                for i in 0..n {
                    let f = |i: u32, j: u32| {
                        c + u * (i as f32 / n as f32 * 2.0 - 1.0)
                            + v * (j as f32 / n as f32 * 2.0 - 1.0)
                    };
                    m.quad([f(i, j), f(i + 1, j), f(i + 1, j + 1), f(i, j + 1)], id);
                    id += 2;
                }
            }
        }
    }
    m
}
