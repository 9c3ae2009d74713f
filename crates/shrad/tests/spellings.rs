//! One scene spelled three ways, as other tools write it (issue "Correct on files from other
//! tools"): transforms baked into the vertices; unit-ish meshes scaled (by 0.3, by 3 and by
//! (1, 0.5, 2)) and rotated by their glTF nodes; and mirrored nodes, written as glTF specifies
//! (the mesh mirrored, its triangles reversed, the node mirroring it back: clockwise front
//! faces in the world under a negative determinant). Each goes through `write_gltf` and
//! `load`. At one patch size all three must give the same patches and the same light.

use crate::common;

use std::collections::HashMap;
use std::path::Path;

use glam::{Affine3A, Mat3, Quat, Vec3};
use shrad::dispersive::{Dispersive, DispersiveOptions};
use shrad::grid::{Grid, GridOptions};
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::{Material, Mesh, Object, Role, Scene};
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

/// A box of size `size` centred at the origin, faces outward (or inward).
fn cuboid(size: Vec3, inward: bool) -> Mesh {
    shrad::scene::box_mesh(0.5 * size, inward)
}

/// The scene's parts: (name, role, mesh as the file instances it, node transform, material).
fn parts() -> Vec<(&'static str, Role, Mesh, Affine3A, Material)> {
    let diffuse = |r: f32, g: f32, b: f32| Material::diffuse(Vec3::new(r, g, b));
    let rot_y = |deg: f32| Quat::from_rotation_y(deg.to_radians());
    let light_quad = common::ceiling_light();
    vec![
        (
            "room",
            Role::Boundary,
            cuboid(Vec3::ONE, true),
            Affine3A::from_scale_rotation_translation(
                Vec3::new(4.0, 3.0, 5.0),
                Quat::IDENTITY,
                Vec3::new(0.0, 1.5, 0.0),
            ),
            diffuse(0.7, 0.65, 0.6),
        ),
        (
            "light",
            Role::Light,
            light_quad,
            Affine3A::from_scale_rotation_translation(
                Vec3::new(1.0, 1.0, 0.6),
                Quat::IDENTITY,
                Vec3::new(0.0, 2.95, 0.0),
            ),
            Material {
                reflectance: Vec3::ZERO,
                emitted_radiance: Vec3::splat(8.0),
                double_sided: false,
                ..Default::default()
            },
        ),
        (
            // A 3 m cube scaled by 0.3 (0.9 m), turned 30 degrees.
            "block_small",
            Role::Interior,
            cuboid(Vec3::splat(3.0), false),
            Affine3A::from_scale_rotation_translation(
                Vec3::splat(0.3),
                rot_y(30.0),
                Vec3::new(-1.0, 0.45, -1.0),
            ),
            diffuse(0.8, 0.2, 0.2),
        ),
        (
            // A 0.2 x 0.4 x 0.2 box scaled by 3 (a 0.6 x 1.2 x 0.6 pillar).
            "pillar",
            Role::Interior,
            cuboid(Vec3::new(0.2, 0.4, 0.2), false),
            Affine3A::from_scale_rotation_translation(
                Vec3::splat(3.0),
                rot_y(-15.0),
                Vec3::new(1.2, 0.6, 0.8),
            ),
            diffuse(0.2, 0.7, 0.3),
        ),
        (
            // A unit cube scaled by (1, 0.5, 2), turned -20 degrees: non-uniform under rotation.
            "slab",
            Role::Interior,
            cuboid(Vec3::ONE, false),
            Affine3A::from_scale_rotation_translation(
                Vec3::new(1.0, 0.5, 2.0),
                rot_y(-20.0),
                Vec3::new(0.3, 0.25, -0.2),
            ),
            diffuse(0.3, 0.4, 0.9),
        ),
    ]
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Spelling {
    Baked,
    Scaled,
    Mirrored,
}

fn scene(spelling: Spelling) -> Scene {
    let mirror = Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    let objects = parts()
        .into_iter()
        .map(|(name, role, mesh, node, material)| {
            let (mesh, node) = match spelling {
                Spelling::Baked => (mesh.transformed(node), Affine3A::IDENTITY),
                Spelling::Scaled => (mesh, node),
                // glTF's rule: under a negative determinant the front faces are clockwise in
                // the world, i.e. the mirrored mesh keeps its front on its own CCW side.
                Spelling::Mirrored => {
                    let mut m = mesh.transformed(mirror);
                    m.triangles.iter_mut().for_each(|t| t.swap(1, 2));
                    (m, node * mirror)
                }
            };
            let mut o = Object::new(name, mesh, material);
            o.role = Some(role);
            o.world_from_object = node;
            o
        })
        .collect();
    Scene {
        source: format!("{spelling:?}"),
        objects,
        ..Default::default()
    }
}

/// The scene written by `write_gltf` and read back by `load`, as a user's file would be.
fn through_gltf(spelling: Spelling, dir: &Path) -> Scene {
    let path = dir.join(format!("{spelling:?}.gltf"));
    shrad::scene::write_gltf(&scene(spelling), &path).unwrap();
    shrad::scene::load(&path, &Default::default()).unwrap()
}

const PATCH_SIZE: f32 = 0.25;

/// For each patch of `b`, the patch of `a` at the same place facing the same way.
fn match_patches(a: &World, b: &World) -> Vec<usize> {
    let q = PATCH_SIZE * 0.1;
    let key = |c: Vec3| (c / q).round().as_ivec3().to_array();
    let mut map: HashMap<[i32; 3], Vec<usize>> = HashMap::new();
    for i in 0..a.patches.len() {
        map.entry(key(a.patches.centre[i])).or_default().push(i);
    }
    (0..b.patches.len())
        .map(|j| {
            let (c, n) = (b.patches.centre[j], b.patches.normal[j]);
            let k = key(c);
            let mut best = (f32::INFINITY, usize::MAX);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let kk = [k[0] + dx, k[1] + dy, k[2] + dz];
                        for &i in map.get(&kk).into_iter().flatten() {
                            let d = (a.patches.centre[i] - c).length();
                            if a.patches.normal[i].dot(n) > 0.99 && d < best.0 {
                                best = (d, i);
                            }
                        }
                    }
                }
            }
            assert!(best.0 < 1e-3, "patch {j} at {c} (normal {n}) has no twin");
            best.1
        })
        .collect()
}

/// Area-weighted relative L2 difference of `b` from `a` over matched patches (lights out).
fn difference(wa: &World, a: &[Vec3], wb: &World, b: &[Vec3], to_a: &[usize]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (j, &i) in to_a.iter().enumerate() {
        if wb.patches.role(j) == Role::Light {
            continue;
        }
        let w = wb.patches.area[j] as f64;
        num += w * (b[j] - a[i]).length_squared() as f64;
        den += w * a[i].length_squared() as f64;
    }
    assert!(wa.patches.len() == wb.patches.len());
    (num / den).sqrt()
}

fn solutions(world: &World) -> [Vec<Vec3>; 3] {
    let reference = solve(world, &ReferenceOptions::fast(), &NoProgress).0;
    let mut d = Dispersive::new(world, DispersiveOptions::improved()).unwrap();
    d.converge(world, 6);
    let mut g = Grid::new(world, GridOptions::paper(4)).unwrap();
    let changes = Default::default();
    for _ in 0..8 {
        g.step(world, &changes);
    }
    [reference, d.radiosity().to_vec(), g.radiosity().to_vec()]
}

#[test]
fn three_spellings_give_the_same_patches_and_light() {
    let dir = std::env::temp_dir().join(format!("shrad-spellings-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let worlds: Vec<World> = [Spelling::Baked, Spelling::Scaled, Spelling::Mirrored]
        .into_iter()
        .map(|s| {
            World::new(
                through_gltf(s, &dir),
                PatchSizing::Size(PATCH_SIZE),
                Backend::Auto,
            )
            .unwrap()
        })
        .collect();
    let _ = std::fs::remove_dir_all(&dir);

    // Patches: the same count and the same total area, per object too.
    let base = &worlds[0];
    for w in &worlds[1..] {
        let (na, nb) = (base.patches.len() as f64, w.patches.len() as f64);
        assert!(
            (na - nb).abs() <= 0.01 * na,
            "{}: {nb} patches vs {na}",
            w.scene.source
        );
        for o in 0..base.scene.objects.len() {
            let area = |w: &World| {
                w.patches
                    .range(o)
                    .map(|p| w.patches.area[p] as f64)
                    .sum::<f64>()
            };
            let (aa, ab) = (area(base), area(w));
            assert!(
                (aa - ab).abs() <= 1e-4 * aa,
                "{} object {o}: area {ab} vs {aa}",
                w.scene.source
            );
        }
        // Every patch's front faces the same way (mirrored nodes must not turn them round).
        let to_base = match_patches(base, w);
        assert_eq!(to_base.len(), w.patches.len());
    }

    // Light: each solver's answer is the same under every spelling. The reference and the
    // grid see identical patches and agree to float noise. The dispersive solver's probe box
    // is the object's box in its own frame: the scaled and mirrored spellings keep the
    // node's rotation and so the same box, and agree as closely; the baked spelling has lost
    // the rotation, so its turned objects get world-aligned (looser) boxes, a different
    // input to the paper's method (measured 1.4 %, docs/results.md).
    let sols: Vec<[Vec<Vec3>; 3]> = worlds.iter().map(solutions).collect();
    let total = |b: &[Vec3], w: &World| -> f64 {
        (0..w.patches.len())
            .map(|i| (b[i] * w.patches.area[i]).element_sum() as f64)
            .sum()
    };
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        let (wa, wb) = (&worlds[a], &worlds[b]);
        let to_a = match_patches(wa, wb);
        for (k, name) in ["reference", "dispersive", "grid"].iter().enumerate() {
            let d = difference(wa, &sols[a][k], wb, &sols[b][k], &to_a);
            let (ta, tb) = (total(&sols[a][k], wa), total(&sols[b][k], wb));
            let flux = (ta - tb).abs() / ta;
            eprintln!(
                "{} vs {} {name}: per-patch difference {:.3} %, total flux difference {:.4} %",
                wb.scene.source,
                wa.scene.source,
                100.0 * d,
                100.0 * flux
            );
            let limit = if name == &"dispersive" && a == 0 {
                0.02
            } else {
                0.005
            };
            assert!(
                flux < 0.005,
                "{name}: total flux differs by {:.3} %",
                100.0 * flux
            );
            assert!(
                d < limit,
                "{} vs {} {name}: differs by {:.3} %",
                wb.scene.source,
                wa.scene.source,
                100.0 * d
            );
        }
    }
}

#[test]
fn polar_split_keeps_the_transform_and_a_rigid_part() {
    for m in [
        Affine3A::from_scale_rotation_translation(
            Vec3::new(1.0, 0.5, 2.0),
            Quat::from_rotation_y(0.4),
            Vec3::X,
        ),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(-0.3, 0.3, 0.3),
            Quat::from_rotation_x(1.0),
            Vec3::Y,
        ),
        // A shear.
        Affine3A::from_mat3(Mat3::from_cols(Vec3::X, Vec3::new(0.5, 1.0, 0.0), Vec3::Z)),
    ] {
        let (rigid, shape) = shrad::patches::split_rest_transform(m);
        let back = rigid * Affine3A::from_mat3(shape);
        assert!(back.abs_diff_eq(m, 1e-5), "{back:?} vs {m:?}");
        let r = Mat3::from(rigid.matrix3);
        assert!((r.transpose() * r).abs_diff_eq(Mat3::IDENTITY, 1e-5));
        assert!((r.determinant() - 1.0).abs() < 1e-5);
        assert!(
            (shape - shape.transpose()).abs_diff_eq(Mat3::ZERO, 1e-4),
            "{shape:?}"
        );
    }
}
