//! Random rays, probe captures, moving objects and a closed room checked against the f64
//! brute force, on every backend.

use super::*;

#[test]
fn random_rays_match_reference_and_each_other() {
    let (meshes, xf) = random_scene(0x5eed, 40);
    let mut rng = Rng(42);
    let n = 3000;
    let (origins, dirs) = random_rays(&mut rng, n, 5.0);
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

/// Shadow rays among a few objects equal shadow rays with every other object excluded, on
/// every backend, whether the objects keep ray-mask bits of their own (Embree's mask path:
/// 40 objects, 3 and 5 flagged) or share one (35: the exclusion path).
#[test]
fn occluded_among_equals_occluded_with_the_others_excluded() {
    let (meshes, xf) = random_scene(0xfeed, 40);
    let mut rng = Rng(7);
    let n = 4000;
    let point = |rng: &mut Rng| Vec3::new(rng.f(), rng.f(), rng.f()) * 10.0 - 5.0;
    let from: Vec<Vec3> = (0..n).map(|_| point(&mut rng)).collect();
    let to: Vec<Vec3> = (0..n).map(|_| point(&mut rng)).collect();
    for b in backends() {
        let refs: Vec<MeshRef<'_>> = meshes
            .iter()
            .enumerate()
            .map(|(i, m)| MeshRef {
                often_excluded: i == 3 || i == 5,
                ..m.r()
            })
            .collect();
        let v = build(b, &refs, &xf).unwrap();
        for among in [&[3u32][..], &[3, 5][..], &[35][..], &[3, 35][..]] {
            let others: Vec<u32> = (0..40).filter(|o| !among.contains(o)).collect();
            let (mut a, mut e) = (vec![false; n], vec![false; n]);
            v.occluded_among(&from, &to, 1e-4, among, &mut a);
            v.occluded(&from, &to, 1e-4, &others, &mut e);
            let blocked = e.iter().filter(|&&x| x).count();
            assert!(blocked > 20, "{b:?} {among:?}: too few blocked ({blocked})");
            assert_eq!(a, e, "{b:?} {among:?}");
        }
    }
}
