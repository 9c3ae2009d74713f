//! Tests of the patches: squares, welding, counts, areas, normals.

use super::weld::quantum;
use super::*;

#[test]
fn cornell_walls_become_squares_and_area_is_kept() {
    let scene = shrad_scene::cornell_box();
    let patches = Patches::build(&scene, PatchSizing::Size(20.0));
    for (o, object) in scene.objects.iter().enumerate() {
        let area: f32 = patches.range(o).map(|p| patches.area[p]).sum();
        let want = object.mesh.transformed(object.world_from_object).area();
        assert!(
            (area - want).abs() < 1e-3 * want,
            "{}: {area} vs {want}",
            object.name
        );
        assert!(
            patches.range(o).all(|p| patches.is_quad[p]),
            "{} has triangles",
            object.name
        );
    }
    // Walls of ~556 at h = 20 give 28 cells per side.
    let floor = patches.range(0);
    assert_eq!(floor.len(), 28 * 28);
    let max_edge = patches
        .corners
        .iter()
        .map(|c| (c[1] - c[0]).length().max((c[3] - c[0]).length()))
        .fold(0.0, f32::max);
    assert!(max_edge <= 20.0 + 1e-3, "max edge {max_edge}");
}

#[test]
fn corners_weld_across_facets_but_not_across_creases() {
    // A tessellated sphere (facets 15 degrees apart): one shading vertex per position.
    let mut scene = shrad_scene::room(&Default::default());
    scene.objects.retain(|o| o.name.starts_with("sphere"));
    scene.objects.truncate(1);
    let sphere = Patches::build(&scene, PatchSizing::Size(0.05));
    let positions: std::collections::HashSet<[i64; 3]> = sphere
        .corners
        .iter()
        .flatten()
        .map(|p| {
            (*p / quantum(&sphere.shapes[0]))
                .round()
                .as_i64vec3()
                .to_array()
        })
        .collect();
    assert_eq!(sphere.shading_vertex_count, positions.len());
    // A box: the 8 corners of the short box each belong to 3 faces at right angles,
    // which must not share a vertex.
    let scene = shrad_scene::cornell_box();
    let o = scene
        .objects
        .iter()
        .position(|o| o.name.contains("short"))
        .expect("the short box");
    let patches = Patches::build(&scene, PatchSizing::Size(20.0));
    for i in patches.range(o) {
        for j in patches.range(o) {
            let shared = patches.corner_vertex[i]
                .iter()
                .any(|v| patches.corner_vertex[j].contains(v));
            if shared {
                assert!(
                    patches.normal[i].dot(patches.normal[j]) > 0.9,
                    "patches {i} and {j} share a vertex across a crease"
                );
            }
        }
    }
}

#[test]
fn patch_count_target_is_met() {
    let scene = shrad_scene::cornell_box();
    let patches = Patches::build(&scene, PatchSizing::Count(20_000));
    let n = patches.len() as f32;
    assert!((n - 20_000.0).abs() < 0.1 * 20_000.0, "{n}");
}

/// Long slivers are cut into far more cells than their area says: a unit box with one
/// vertex pulled 1000 away asked 3,000 patches and got 119,031 (the bisection's bracket was
/// fixed around the area's size).
#[test]
fn patch_count_target_is_met_with_long_slivers() {
    let mut scene = shrad_scene::cornell_box();
    scene.objects.truncate(1);
    let mesh = &mut scene.objects[0].mesh;
    let far = mesh.positions[0] + glam::Vec3::new(-1000.0 * 556.0, 0.0, 0.0);
    mesh.positions[0] = far;
    let patches = Patches::build(&scene, PatchSizing::Count(3_000));
    let n = patches.len() as f32;
    assert!((n - 3_000.0).abs() < 0.1 * 3_000.0, "{n}");
}

#[test]
fn triangles_subdivide_with_area_kept() {
    let mut scene = shrad_scene::room(&Default::default());
    scene.objects.retain(|o| o.name.starts_with("sphere"));
    let patches = Patches::build(&scene, PatchSizing::Size(0.05));
    let o = &scene.objects[0];
    let area: f32 = patches.range(0).map(|p| patches.area[p]).sum();
    assert!((area - o.mesh.area()).abs() < 1e-3 * area);
    // Normals of a closed sphere point outward.
    let centre: Vec3 = o.world_from_object.translation.into();
    assert!(patches
        .range(0)
        .all(|p| patches.normal[p].dot(patches.centre[p] - centre) > 0.0));
}

#[test]
fn world_normals_follow_rotation() {
    let scene = shrad_scene::cornell_box();
    let patches = Patches::build(&scene, PatchSizing::Size(50.0));
    let short = scene
        .objects
        .iter()
        .position(|o| o.name == "short_block")
        .unwrap();
    // The block's top face points up in the world.
    assert!(patches.range(short).any(|p| patches.normal[p].y > 0.999));
    assert!(patches
        .range(short)
        .all(|p| (patches.normal[p].length() - 1.0).abs() < 1e-4));
}

/// An object's world box and sphere are kept as it moves (`Patches::set_transform`): after
/// a turn, a mirror and a stretch they equal the ones found again from its shape, the box
/// holds every corner of its patches, and so does the sphere, which is tighter than the
/// box's own for a ball. Fails if a move leaves them where the object was, or if the sphere
/// misses a patch (a stretch taken as a uniform scale would).
#[test]
fn an_objects_world_box_and_sphere_follow_it_and_hold_its_patches() {
    let mut scene = shrad_scene::room(&Default::default());
    scene.objects.retain(|o| o.name.starts_with("sphere"));
    scene.objects.truncate(1);
    let mut patches = Patches::build(&scene, PatchSizing::Size(0.1));
    let moves = [
        Affine3A::from_translation(Vec3::new(0.3, 0.1, -0.2)),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(1.5, -0.7, 1.1),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.9, -0.4),
            Vec3::new(-1.0, 0.5, 2.0),
        ),
    ];
    for m in moves {
        patches.set_transform(0, m * patches.world_from_local[0]);
        let (b, (c, r)) = (patches.world_box(0), patches.world_sphere(0).unwrap());
        assert_eq!(b, patches.shape_box(0));
        assert_eq!(Some((c, r)), patches.shape_sphere(0));
        assert!(
            r < b.bounding_sphere().1,
            "the sphere {r} is no tighter than the box's"
        );
        for p in patches.range(0) {
            for x in patches.world_corners(p) {
                assert!(
                    b.padded(Vec3::splat(1e-5)).contains(x),
                    "{x} outside the box"
                );
                assert!(
                    (x - c).length() <= r * (1.0 + 1e-5),
                    "{x} outside the sphere"
                );
            }
        }
    }
}

/// A target below one patch a face gives the fewest patches at a size no larger than the
/// scene's diagonal (it was 8.2e22 for five patches of the Cornell box).
#[test]
fn a_target_below_one_patch_a_face_gives_a_size_within_the_scene() {
    let scene = shrad_scene::cornell_box();
    let diagonal = scene.bounds().unwrap().diagonal();
    let fewest = Patches::plan(&scene, PatchSizing::Size(diagonal)).count;
    for n in [1, 5] {
        let plan = Patches::plan(&scene, PatchSizing::Count(n));
        assert!(plan.patch_size <= diagonal, "{n}: {}", plan.patch_size);
        assert_eq!(plan.count, fewest, "{n}");
    }
}
