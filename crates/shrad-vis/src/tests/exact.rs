//! Answers known in closed form: boxes, quads and their faces, exclusion, occlusion with an
//! epsilon, degenerate input, and which backend is chosen.

use super::*;

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

/// A backend seen only through the trait's default `closest_within` (whole rays, the hits
/// beyond dropped).
struct DefaultWithin(Box<dyn Visibility>);

impl Visibility for DefaultWithin {
    fn name(&self) -> &'static str {
        "default closest_within"
    }
    fn object_count(&self) -> usize {
        self.0.object_count()
    }
    fn set_transform(&mut self, object: usize, world_from_object: Affine3A) {
        self.0.set_transform(object, world_from_object)
    }
    fn commit(&mut self) {
        self.0.commit()
    }
    fn closest(&self, o: &[Vec3], d: &[Vec3], t_min: f32, exclude: &[u32], out: &mut [Hit]) {
        self.0.closest(o, d, t_min, exclude, out)
    }
    fn capture(&self, p: &[Vec3], d: &[Vec3], t_min: f32, exclude: &[u32], out: &mut [Hit]) {
        self.0.capture(p, d, t_min, exclude, out)
    }
    fn occluded(&self, f: &[Vec3], t: &[Vec3], eps: f32, exclude: &[u32], out: &mut [bool]) {
        self.0.occluded(f, t, eps, exclude, out)
    }
}

#[test]
fn closest_within_is_closest_cut_at_t_max() {
    // Rays from inside a box of objects: each one's nearest hit within t_max, and a miss
    // where it lies beyond, on every backend (Embree's tfar, the BVH's t_max) and through
    // the trait's default; with an object excluded too.
    let (meshes, xf) = random_scene(7, 24);
    let mut rng = Rng(99);
    let n = 2000;
    let (origins, dirs) = random_rays(&mut rng, n, 4.0);
    for b in backends() {
        let whole = make(b, &meshes, &xf);
        let default = DefaultWithin(make(b, &meshes, &xf));
        for exclude in [&[][..], &[3u32][..]] {
            let mut all = vec![Hit::MISS; n];
            whole.closest(&origins, &dirs, 1e-4, exclude, &mut all);
            let hits = all.iter().filter(|h| h.is_hit()).count();
            assert!(
                hits > n / 10,
                "{b:?}: the rays must meet something ({hits})"
            );
            for t_max in [0.5f32, 2.0, 6.0] {
                let cut = all.iter().filter(|h| h.is_hit() && h.t > t_max).count();
                assert!(
                    cut > 0 && cut < hits,
                    "{b:?} t_max {t_max}: {cut} of {hits}"
                );
                for v in [&*whole as &dyn Visibility, &default] {
                    let mut within = vec![Hit::MISS; n];
                    v.closest_within(&origins, &dirs, (1e-4, t_max), exclude, &mut within);
                    for (i, (w, a)) in within.iter().zip(&all).enumerate() {
                        let want = if a.is_hit() && a.t <= t_max {
                            *a
                        } else {
                            Hit::MISS
                        };
                        assert_eq!(
                            (w.is_hit(), w.object, w.id),
                            (want.is_hit(), want.object, want.id),
                            "{} {b:?} ray {i} t_max {t_max}: {w:?} against {a:?}",
                            v.name()
                        );
                        if w.is_hit() {
                            assert!((w.t - a.t).abs() <= 1e-4 * a.t.max(1.0), "{w:?} {a:?}");
                        }
                    }
                }
            }
        }
    }
}
