//! Checks of the reference solver that can be derived (spec section 7): analytic form
//! factors, reciprocity, the furnace.

use glam::Vec3;
use shrad::reference::{form_factors, solve, ReferenceOptions};
use shrad::scene::{Material, Mesh, Object, Role, Scene};
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

fn quad(p: [Vec3; 4]) -> Mesh {
    Mesh::new(p.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
}

fn scene_of(meshes: Vec<Mesh>, material: Material) -> Scene {
    Scene {
        source: "test".into(),
        objects: meshes
            .into_iter()
            .enumerate()
            .map(|(i, m)| {
                let mut o = Object::new(format!("o{i}"), m, material.clone());
                o.role = Some(Role::Boundary);
                o
            })
            .collect(),
        ..Default::default()
    }
}

fn backends() -> Vec<Backend> {
    shrad::vis::available_backends()
}

/// F from patch 0 to patch 1 with many rays, both squares one patch each.
fn ff01(scene: Scene, backend: Backend) -> f32 {
    let world = World::new(scene, PatchSizing::Size(10.0), backend).unwrap();
    assert_eq!(world.patches.len(), 2);
    let ff = form_factors(&world, &[0], 1 << 20, &NoProgress).unwrap();
    ff.row(0)
        .iter()
        .filter(|(j, _)| *j == 1)
        .map(|(_, f)| f)
        .sum()
}

#[test]
fn parallel_unit_squares_one_apart() {
    let v = Vec3::new;
    for b in backends() {
        // Facing each other: bottom faces up, top faces down.
        let s = scene_of(
            vec![
                quad([v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]),
                quad([v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)]),
            ],
            Material::diffuse(Vec3::splat(0.5)),
        );
        let f = ff01(s, b);
        assert!((f - 0.1998).abs() < 0.01 * 0.1998, "{b:?}: F = {f}");
    }
}

#[test]
fn perpendicular_unit_squares_sharing_an_edge() {
    let v = Vec3::new;
    for b in backends() {
        let s = scene_of(
            vec![
                quad([v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]), // z = 0, normal +z
                quad([v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)]), // x = 0, normal +x
            ],
            Material::diffuse(Vec3::splat(0.5)),
        );
        let f = ff01(s, b);
        assert!((f - 0.2).abs() < 0.01 * 0.2, "{b:?}: F = {f}");
    }
}

#[test]
fn reciprocity_of_unequal_patches() {
    let v = Vec3::new;
    let s = scene_of(
        vec![
            quad([v(0., 0., 0.), v(2., 0., 0.), v(2., 1., 0.), v(0., 1., 0.)]),
            quad([v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 0.5), v(0., 0., 0.5)]),
        ],
        Material::diffuse(Vec3::splat(0.5)),
    );
    let world = World::new(s, PatchSizing::Size(10.0), Backend::Auto).unwrap();
    let ff = form_factors(&world, &[0, 1], 1 << 19, &NoProgress).unwrap();
    let f01: f32 = ff
        .row(0)
        .iter()
        .filter(|(j, _)| *j == 1)
        .map(|(_, f)| f)
        .sum();
    let f10: f32 = ff
        .row(1)
        .iter()
        .filter(|(j, _)| *j == 0)
        .map(|(_, f)| f)
        .sum();
    let (a0, a1) = (world.patches.area[0], world.patches.area[1]);
    assert!(f01 > 0.0 && f10 > 0.0);
    assert!(
        (a0 * f01 - a1 * f10).abs() < 0.01 * a0 * f01,
        "A0 F01 = {}, A1 F10 = {}",
        a0 * f01,
        a1 * f10
    );
}

/// A closed box, every wall emitting `M` and reflecting `rho`: `B = M / (1 - rho)`.
#[test]
fn furnace_box() {
    let rho = 0.5f32;
    let le = 1.0f32;
    let mut material = Material::diffuse(Vec3::splat(rho));
    material.emitted_radiance = Vec3::splat(le);
    // A unit cube, six inward walls.
    let v = Vec3::new;
    let walls = [
        [v(0., 0., 0.), v(0., 0., 1.), v(1., 0., 1.), v(1., 0., 0.)],
        [v(0., 1., 0.), v(1., 1., 0.), v(1., 1., 1.), v(0., 1., 1.)],
        [v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)],
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
        [v(1., 0., 0.), v(1., 0., 1.), v(1., 1., 1.), v(1., 1., 0.)],
        [v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)],
    ];
    let scene = scene_of(walls.iter().map(|w| quad(*w)).collect(), material);
    for b in backends() {
        let world = World::new(scene.clone(), PatchSizing::Size(0.125), b).unwrap();
        let (radiosity, stats) = solve(&world, &ReferenceOptions::standard(), &NoProgress);
        assert!(stats.converged);
        let want = std::f32::consts::PI * le / (1.0 - rho);
        let worst = radiosity
            .iter()
            .map(|b| ((b.x - want) / want).abs())
            .fold(0.0, f32::max);
        assert!(worst < 0.005, "{b:?}: worst relative deviation {worst}");
    }
}
