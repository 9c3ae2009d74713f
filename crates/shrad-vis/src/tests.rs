//! One test body per property, run over every backend in this build, checked against exact
//! answers or a brute-force f64 reference.

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

#[test]
fn closest_on_unit_box() {
    for b in backends() {
        let v = make(b, &[cube(100)], &[Affine3A::IDENTITY]);
        assert_eq!(v.object_count(), 1);
        // From outside, towards -x face... +x face from +x side: front.
        let h = one(&*v, Vec3::new(3.0, 0.1, 0.2), -Vec3::X, &[]);
        assert!(h.is_hit(), "{b:?}");
        assert!((h.t - 2.5).abs() < 1e-5, "{b:?} {h:?}");
        assert_eq!(h.id / 10, 10, "{b:?} {h:?}"); // face 0 (+x) of base 100
        assert_eq!(h.object, 0);
        assert!(h.front, "{b:?}");
        // From inside: back faces.
        for (f, d) in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]
            .into_iter()
            .enumerate()
        {
            let h = one(&*v, Vec3::new(0.01, 0.02, 0.03), d, &[]);
            assert!(h.is_hit(), "{b:?}");
            assert_eq!((h.id - 100) / 10, f as u32, "{b:?} {d} {h:?}");
            assert!(!h.front, "{b:?}");
            let expect = 0.5 - Vec3::new(0.01, 0.02, 0.03).dot(d);
            assert!((h.t - expect).abs() < 1e-5, "{b:?} {h:?} {expect}");
        }
        // Exact triangle: on the +z face, point (0.3, -0.3) lies in triangle (p0, p1, p2)
        // (u - v > 0 side) => id base + 40.
        let h = one(&*v, Vec3::new(0.3, -0.3, 2.0), -Vec3::Z, &[]);
        assert_eq!(h.id, 140, "{b:?} {h:?}");
        let h = one(&*v, Vec3::new(-0.3, 0.3, 2.0), -Vec3::Z, &[]);
        assert_eq!(h.id, 141, "{b:?} {h:?}");
        assert!((h.t - 1.5).abs() < 1e-5);
        // Misses.
        let h = one(&*v, Vec3::new(3.0, 0.1, 0.2), Vec3::X, &[]);
        assert_eq!(h.id, NO_HIT);
        assert!(!h.is_hit());
        let h = one(&*v, Vec3::new(3.0, 0.7, 0.2), -Vec3::X, &[]);
        assert!(!h.is_hit(), "{b:?}");
        // t_min skips the near face.
        let mut out = [Hit::MISS];
        v.closest(&[Vec3::new(3.0, 0.1, 0.2)], &[-Vec3::X], 2.6, &[], &mut out);
        assert_eq!(out[0].id / 10, 11, "{b:?} {:?}", out[0]); // -x face, from inside
        assert!((out[0].t - 3.5).abs() < 1e-5);
        assert!(!out[0].front);
    }
}

#[test]
fn transformed_quads_and_front() {
    // Object 0: a quad in z = 0 facing +z, rotated to face +x and moved to x = 2.
    // Object 1: the same quad mirrored in x at z = -3: the world winding flips, but by the
    // glTF rule the front stays the object frame's counter-clockwise side, +z (normal L^-T n).
    let mut q = Mesh::default();
    q.quad(
        [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        7,
    );
    let x0 = Affine3A::from_rotation_translation(
        Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        Vec3::new(2.0, 0.0, 0.0),
    );
    let x1 = Affine3A::from_translation(Vec3::new(0.0, 0.0, -3.0))
        * Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    for b in backends() {
        let v = make(b, &[q.clone(), q.clone()], &[x0, x1]);
        let h = one(&*v, Vec3::new(5.0, 0.2, 0.3), -Vec3::X, &[]);
        assert_eq!(h.object, 0, "{b:?} {h:?}");
        assert!((h.t - 3.0).abs() < 1e-5);
        assert!(h.front, "{b:?}");
        assert!(h.id == 7 || h.id == 8);
        let h = one(&*v, Vec3::new(0.0, 0.2, 0.3), Vec3::X, &[]);
        assert_eq!(h.object, 0);
        assert!(!h.front, "{b:?}");
        // Mirrored quad: from above (+z side) it is the front.
        let h = one(&*v, Vec3::new(0.1, 0.2, 0.0), -Vec3::Z, &[]);
        assert_eq!(h.object, 1, "{b:?} {h:?}");
        assert!((h.t - 3.0).abs() < 1e-5);
        assert!(h.front, "{b:?}");
        let h = one(&*v, Vec3::new(0.1, 0.2, -5.0), Vec3::Z, &[]);
        assert_eq!(h.object, 1);
        assert!(!h.front, "{b:?}");
    }
}

#[test]
fn exclusion() {
    let xf = [
        Affine3A::IDENTITY,
        Affine3A::from_translation(Vec3::new(3.0, 0.0, 0.0)),
        Affine3A::from_translation(Vec3::new(6.0, 0.0, 0.0)),
    ];
    let meshes = [cube(0), cube(1000), cube(2000)];
    for b in backends() {
        let v = make(b, &meshes, &xf);
        let o = Vec3::new(0.0, 0.1, 0.05);
        assert_eq!(one(&*v, o, Vec3::X, &[]).object, 0);
        let h = one(&*v, o, Vec3::X, &[0]);
        assert_eq!(h.object, 1, "{b:?}");
        assert!((h.t - 2.5).abs() < 1e-5);
        assert!(h.front);
        assert_eq!(h.id / 10, 101, "{b:?} {h:?}"); // -x face of cube 1: 1000 + 10 * 1 + tri
        let h = one(&*v, o, Vec3::X, &[1, 0]);
        assert_eq!(h.object, 2, "{b:?}");
        assert!((h.t - 5.5).abs() < 1e-5);
        assert!(!one(&*v, o, Vec3::X, &[0, 1, 2]).is_hit());
        // Excluding an object not on the path changes nothing.
        let h = one(&*v, o, Vec3::X, &[2]);
        assert_eq!(h.object, 0);
        assert!((h.t - 0.5).abs() < 1e-5);
        // Capture with exclusion from the centre of object 1 sees objects 0 and 2.
        let dirs = [Vec3::X, -Vec3::X, Vec3::Y];
        let mut out = [Hit::MISS; 3];
        v.capture(&[Vec3::new(3.0, 0.0, 0.0)], &dirs, 0.0, &[1], &mut out);
        assert_eq!(out[0].object, 2, "{b:?}");
        assert_eq!(out[1].object, 0, "{b:?}");
        assert!((out[0].t - 2.5).abs() < 1e-5 && (out[1].t - 2.5).abs() < 1e-5);
        assert!(!out[2].is_hit());
        // Occlusion with exclusion.
        let mut occ = [false; 2];
        let from = [Vec3::new(-2.0, 0.0, 0.0), Vec3::new(-2.0, 0.0, 0.0)];
        let to = [Vec3::new(4.5, 0.0, 0.0), Vec3::new(4.5, 0.0, 0.0)];
        v.occluded(&from[..1], &to[..1], 1e-4, &[0], &mut occ[..1]);
        assert!(occ[0], "{b:?}");
        v.occluded(&from[..1], &to[..1], 1e-4, &[0, 1], &mut occ[..1]);
        assert!(!occ[0], "{b:?}");
        v.occluded(&from, &to, 1e-4, &[], &mut occ);
        assert!(occ[0] && occ[1]);
    }
}

#[test]
fn occluded_with_eps() {
    // A quad facing +z at z = 0.
    let mut q = Mesh::default();
    q.quad(
        [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        0,
    );
    for b in backends() {
        let v = make(b, &[q.clone()], &[Affine3A::IDENTITY]);
        let from = [
            Vec3::new(0.1, 0.1, 1.0), // ends on the quad: not occluded (eps)
            Vec3::new(0.1, 0.1, 1.0), // passes through it
            Vec3::new(0.1, 0.1, 0.0), // starts on it, goes up
            Vec3::new(0.1, 0.1, 1.0), // stops short
            Vec3::new(0.1, 0.1, 1.0), // beside it
            Vec3::new(0.3, 0.3, 0.5), // zero length
        ];
        let to = [
            Vec3::new(0.2, -0.3, 0.0),
            Vec3::new(0.2, -0.3, -1.0),
            Vec3::new(-0.5, 0.7, 2.0),
            Vec3::new(0.1, 0.1, 0.01),
            Vec3::new(3.0, 0.1, -1.0),
            Vec3::new(0.3, 0.3, 0.5),
        ];
        let mut out = [true; 6];
        v.occluded(&from, &to, 1e-3, &[], &mut out);
        assert_eq!(out, [false, true, false, false, false, false], "{b:?}");
        // Without the eps the end point on the quad would count (or not): just no panic.
        v.occluded(&from, &to, 0.0, &[], &mut out);
        assert!(out[1]);
    }
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

#[test]
fn random_rays_match_reference_and_each_other() {
    let (meshes, xf) = random_scene(0x5eed, 40);
    let mut rng = Rng(42);
    let n = 3000;
    let origins: Vec<Vec3> = (0..n)
        .map(|_| {
            Vec3::new(
                rng.f() * 10.0 - 5.0,
                rng.f() * 10.0 - 5.0,
                rng.f() * 10.0 - 5.0,
            )
        })
        .collect();
    let dirs: Vec<Vec3> = (0..n).map(|_| rng.dir()).collect();
    // 40 objects, more than Embree's 32 mask bits: object 3 is flagged `often_excluded`
    // and gets a bit of its own (excluding it alone takes the mask path); 35 shares the
    // last bit with the other unflagged objects (excluding it takes the filter path).
    let (excl, excl_pair) = ([3u32], [3u32, 35]);
    let mut all = Vec::new();
    for b in backends() {
        let refs: Vec<MeshRef<'_>> = meshes
            .iter()
            .enumerate()
            .map(|(i, m)| MeshRef {
                often_excluded: i == 3,
                ..m.r()
            })
            .collect();
        let v = build(b, &refs, &xf).unwrap();
        for exclude in [&[][..], &excl[..], &excl_pair[..]] {
            let mut out = vec![Hit::MISS; n];
            v.closest(&origins, &dirs, 1e-4, exclude, &mut out);
            let mut ties = 0;
            let mut hits = 0;
            for i in 0..n {
                let r = reference(&meshes, &xf, origins[i], dirs[i], 1e-4, exclude);
                hits += out[i].is_hit() as usize;
                if !agrees(&out[i], &r, &format!("{b:?} ray {i}")) {
                    ties += 1;
                }
                assert!(!exclude.contains(&out[i].object));
            }
            assert!(
                hits > n / 4,
                "{b:?}: too few hits ({hits}) for a meaningful test"
            );
            assert!(ties <= n / 200, "{b:?}: {ties} near-ties / slips");
            all.push(out);
        }
        // Occlusion agrees with closest: segment to just before the hit is free, past it blocked.
        let mut out = vec![Hit::MISS; n];
        v.closest(&origins, &dirs, 1e-4, &[], &mut out);
        let (mut from, mut short, mut long) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            if out[i].is_hit() && out[i].t > 0.01 {
                from.push(origins[i]);
                short.push(origins[i] + dirs[i] * (out[i].t - 0.005));
                long.push(origins[i] + dirs[i] * (out[i].t + 0.005));
            }
        }
        let mut o1 = vec![true; from.len()];
        let mut o2 = vec![false; from.len()];
        v.occluded(&from, &short, 1e-3, &[], &mut o1);
        v.occluded(&from, &long, 1e-3, &[], &mut o2);
        let bad1 = o1.iter().filter(|&&x| x).count();
        let bad2 = o2.iter().filter(|&&x| !x).count();
        assert!(
            bad1 <= from.len() / 200 && bad2 <= from.len() / 200,
            "{b:?}: {bad1} {bad2} of {}",
            from.len()
        );
    }
    // Backends agree with each other except on near-ties.
    if all.len() == 6 {
        for k in 0..3 {
            let (a, b) = (&all[k], &all[k + 3]);
            let diff = a.iter().zip(b).filter(|(x, y)| x.id != y.id).count();
            assert!(diff <= n / 200, "backends differ on {diff} rays");
        }
    }
}

#[test]
fn capture_matches_closest() {
    let (meshes, xf) = random_scene(7, 12);
    let dirs = cube_dirs(12);
    let points = [
        Vec3::ZERO,
        Vec3::new(1.0, -2.0, 0.5),
        Vec3::new(-3.0, 1.0, 2.0),
    ];
    for b in backends() {
        let v = make(b, &meshes, &xf);
        for exclude in [&[][..], &[2u32][..]] {
            let mut cap = vec![Hit::MISS; points.len() * dirs.len()];
            v.capture(&points, &dirs, 1e-4, exclude, &mut cap);
            let origins: Vec<Vec3> = points
                .iter()
                .flat_map(|&p| std::iter::repeat_n(p, dirs.len()))
                .collect();
            let all_dirs: Vec<Vec3> = points.iter().flat_map(|_| dirs.iter().copied()).collect();
            let mut cl = vec![Hit::MISS; origins.len()];
            v.closest(&origins, &all_dirs, 1e-4, exclude, &mut cl);
            let mut diff = 0;
            for (a, c) in cap.iter().zip(&cl) {
                if a.id != c.id {
                    diff += 1;
                } else if a.is_hit() {
                    assert!((a.t - c.t).abs() < 1e-4 * (1.0 + a.t), "{b:?} {a:?} {c:?}");
                    assert_eq!(a.front, c.front);
                    assert_eq!(a.object, c.object);
                }
            }
            assert!(
                diff <= cap.len() / 500,
                "{b:?}: capture and closest differ on {diff}"
            );
            assert!(cap.iter().any(|h| h.is_hit()));
        }
    }
}

#[test]
fn moving_an_object_moves_hits() {
    let meshes = [cube(0), cube(100)];
    for b in backends() {
        let mut v = make(
            b,
            &meshes,
            &[
                Affine3A::IDENTITY,
                Affine3A::from_translation(Vec3::new(3.0, 0.0, 0.0)),
            ],
        );
        let o = Vec3::new(-5.0, 0.1, 0.1);
        assert_eq!(one(&*v, o, Vec3::X, &[]).object, 0);
        // Move object 0 out of the way and object 1 closer, rotated.
        v.set_transform(0, Affine3A::from_translation(Vec3::new(0.0, 10.0, 0.0)));
        v.set_transform(
            1,
            Affine3A::from_rotation_translation(
                Quat::from_rotation_z(0.3),
                Vec3::new(-1.0, 0.0, 0.0),
            ),
        );
        v.commit();
        let h = one(&*v, o, Vec3::X, &[]);
        assert_eq!(h.object, 1, "{b:?} {h:?}");
        assert!(h.front);
        let r = reference(
            &meshes,
            &[
                Affine3A::from_translation(Vec3::new(0.0, 10.0, 0.0)),
                Affine3A::from_rotation_translation(
                    Quat::from_rotation_z(0.3),
                    Vec3::new(-1.0, 0.0, 0.0),
                ),
            ],
            o,
            Vec3::X,
            0.0,
            &[],
        );
        assert!((h.t as f64 - r[0].0).abs() < 1e-4, "{b:?} {h:?} {:?}", r[0]);
        let h = one(&*v, Vec3::new(0.0, 5.0, 0.1), Vec3::Y, &[]);
        assert_eq!(h.object, 0, "{b:?}");
        assert!((h.t - 4.5).abs() < 1e-5);
        // A second move, and a commit with nothing changed.
        v.set_transform(0, Affine3A::IDENTITY);
        v.commit();
        v.commit();
        let h = one(&*v, Vec3::new(0.0, 5.0, 0.1), -Vec3::Y, &[]);
        assert_eq!(h.object, 0, "{b:?}");
        assert!((h.t - 4.5).abs() < 1e-5);
    }
}

#[test]
fn degenerate_inputs() {
    for b in backends() {
        // No objects.
        let v = build(b, &[], &[]).unwrap();
        assert_eq!(v.object_count(), 0);
        let mut out = [Hit {
            id: 5,
            object: 1,
            t: 1.0,
            front: true,
        }];
        v.closest(&[Vec3::ZERO], &[Vec3::X], 0.0, &[], &mut out);
        assert!(!out[0].is_hit());
        let mut occ = [true];
        v.occluded(&[Vec3::ZERO], &[Vec3::X], 0.0, &[], &mut occ);
        assert!(!occ[0]);
        v.capture(&[], &[Vec3::X], 0.0, &[], &mut []);
        v.capture(&[Vec3::ZERO], &[], 0.0, &[], &mut []);
        v.closest(&[], &[], 0.0, &[], &mut []);
        // Empty mesh next to a real one, plus a degenerate (zero-area) triangle.
        let empty = Mesh::default();
        let mut deg = cube(0);
        deg.p.push(Vec3::ONE);
        let k = deg.p.len() as u32 - 1;
        deg.t.push([k, k, k]);
        deg.ids.push(999);
        let mut v = make(b, &[empty.clone(), deg, empty], &[Affine3A::IDENTITY; 3]);
        let h = one(&*v, Vec3::new(-3.0, 0.1, 0.1), Vec3::X, &[]);
        assert_eq!(h.object, 1, "{b:?}");
        v.set_transform(0, Affine3A::from_translation(Vec3::X));
        v.commit();
        let h = one(&*v, Vec3::new(-3.0, 0.1, 0.1), Vec3::X, &[0]);
        assert_eq!(h.object, 1, "{b:?}");
        // Wrong lengths are errors, not panics.
        let c = cube(0);
        let bad = MeshRef {
            positions: &c.p,
            triangles: &c.t,
            ids: &c.ids[1..],
            often_excluded: false,
        };
        assert!(matches!(
            build(b, &[bad], &[Affine3A::IDENTITY]),
            Err(VisError::Invalid(_))
        ));
        assert!(matches!(build(b, &[c.r()], &[]), Err(VisError::Invalid(_))));
        let oob = [[0u32, 1, 99]];
        let bad = MeshRef {
            positions: &c.p,
            triangles: &oob,
            ids: &[0],
            often_excluded: false,
        };
        assert!(matches!(
            build(b, &[bad], &[Affine3A::IDENTITY]),
            Err(VisError::Invalid(_))
        ));
    }
}

#[test]
fn backend_selection() {
    let c = cube(0);
    let v = build(Backend::Auto, &[c.r()], &[Affine3A::IDENTITY]).unwrap();
    let best = available_backends()[0];
    assert_eq!(
        v.name(),
        if best == Backend::Embree {
            "embree"
        } else {
            "bvh"
        }
    );
    let e = build(Backend::Embree, &[c.r()], &[Affine3A::IDENTITY]);
    if cfg!(shrad_embree) {
        assert_eq!(e.unwrap().name(), "embree");
    } else {
        match e {
            Err(VisError::Unavailable(msg)) => assert!(msg.contains("libembree-dev")),
            _ => panic!("Embree should be unavailable"),
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

#[test]
fn closed_room_has_no_leaks() {
    let m = room(Vec3::new(10.0, 4.0, 10.0), 32);
    let xf = [Affine3A::from_translation(Vec3::new(0.0, 4.0, 0.0))];
    let dirs = cube_dirs(64);
    let points: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                -7.0 + 2.0 * i as f32,
                3.5 + (i % 3) as f32,
                7.0 - 2.0 * i as f32,
            )
        })
        .collect();
    for b in backends() {
        let v = make(b, std::slice::from_ref(&m), &xf);
        let mut cap = vec![Hit::MISS; points.len() * dirs.len()];
        v.capture(&points, &dirs, 1e-4, &[], &mut cap);
        let origins: Vec<Vec3> = points
            .iter()
            .flat_map(|&p| std::iter::repeat_n(p, dirs.len()))
            .collect();
        let all_dirs: Vec<Vec3> = points.iter().flat_map(|_| dirs.iter().copied()).collect();
        let mut cl = vec![Hit::MISS; origins.len()];
        v.closest(&origins, &all_dirs, 1e-4, &[], &mut cl);
        let leaks_cap: Vec<usize> = (0..cap.len()).filter(|&i| !cap[i].is_hit()).collect();
        let leaks_cl = cl.iter().filter(|h| !h.is_hit()).count();
        for &i in leaks_cap.iter().take(5) {
            let r = reference(
                std::slice::from_ref(&m),
                &xf,
                origins[i],
                all_dirs[i],
                1e-4,
                &[],
            );
            eprintln!(
                "{b:?} leak {i}: {} {} ref {:?}",
                origins[i],
                all_dirs[i],
                &r[..r.len().min(3)]
            );
        }
        assert!(
            leaks_cap.is_empty() && leaks_cl == 0,
            "{b:?}: {} capture / {leaks_cl} closest rays escaped",
            leaks_cap.len()
        );
        assert!(
            cap.iter().all(|h| h.front),
            "{b:?}: inward room seen from inside is front"
        );
    }
}
