//! Files other tools wrote, checked against what those tools measure: a room built and
//! exported by Blender (unapplied scale, a mirrored object, double-sided materials, see
//! `tests/data/README.md`) and the Cornell box as unit primitives scaled into place by
//! their nodes (`validation/cornell_unit_primitives.py`'s layout, rebuilt here).

use std::path::Path;

use shrad::dispersive::{Dispersive, DispersiveOptions};
use shrad::reference::{solve, ReferenceOptions};
use shrad::scene::Role;
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

fn blender_room() -> World {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender_room.glb");
    let scene = shrad::scene::load(&path, &Default::default()).unwrap();
    World::new(scene, PatchSizing::Size(0.1), Backend::Auto).unwrap()
}

#[test]
fn blender_areas_match_blenders_own() {
    let world = blender_room();
    // Blender's bmesh areas of the world-space meshes (printed by the export script).
    let blender = [
        ("room", 94.0),
        ("light", 0.6),
        ("red_box", 2.16),
        ("blue_slab", 1.75),
        ("green_mirrored", 2.24),
    ];
    for (name, area) in blender {
        let o = world
            .scene
            .objects
            .iter()
            .position(|o| o.name == name)
            .unwrap_or_else(|| panic!("no object {name}"));
        let r = world.patches.range(o);
        // Double-sided: each side is a patch of its own; count the file's front side once.
        let sides = if world.scene.objects[o].material.double_sided {
            2.0
        } else {
            1.0
        };
        let ours: f64 = r.map(|p| world.patches.area[p] as f64).sum::<f64>() / sides;
        assert!(
            (ours - area).abs() < 1e-4 * area,
            "{name}: {ours} vs Blender's {area}"
        );
    }
}

#[test]
fn blender_mirrored_object_faces_out_and_the_room_in() {
    let world = blender_room();
    let p = &world.patches;
    for (o, object) in world.scene.objects.iter().enumerate() {
        let centre = object.world_bounds().unwrap().centre();
        // The file's own side (not the double-sided twins): the first of each pair.
        let own: Vec<usize> = p
            .range(o)
            .filter(|&i| p.twin[i] == shrad::patches::NO_PATCH || (p.twin[i] as usize) > i)
            .collect();
        let outward = own
            .iter()
            .filter(|&&i| p.normal[i].dot(p.centre[i] - centre) > 0.0)
            .count();
        match p.object_role[o] {
            Role::Interior => assert_eq!(outward, own.len(), "{}", object.name),
            Role::Boundary => assert_eq!(outward, 0, "{}", object.name),
            Role::Light => {}
        }
    }
}

#[test]
fn blender_room_dispersive_is_close_to_the_reference() {
    let world = blender_room();
    let (reference, stats) = solve(&world, &ReferenceOptions::fast(), &NoProgress);
    // A closed room: the meter closes (the lights' own absorption included).
    assert!(
        (stats.energy.closure() - 1.0).abs() < 0.01,
        "{:?}",
        stats.energy
    );
    let mut d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
    d.converge(&world, 6);
    let e = shrad::metrics::relative_error(&world.patches, d.radiosity(), &reference);
    eprintln!(
        "Blender room: dispersive vs reference {:.2} % (boundary {:.2}, interior {:.2})",
        100.0 * e.overall,
        100.0 * e.boundary,
        100.0 * e.interior
    );
    // Before the double-sided enclosure fix its interior was 35 % too dark.
    assert!(e.overall < 0.05 && e.interior < 0.10, "{e:?}");
    assert!(d
        .radiosity()
        .iter()
        .all(|b| b.is_finite() && b.min_element() >= 0.0));
}

/// Every model of the corpus (the Khronos fixtures, Blender's room, trimesh's scene, and the files of
/// `$SHRAD_EXTRA_MODELS`, a folder, when set) either is refused with a message or loads with
/// patch areas that sum to the world area of each transformed input mesh.
#[test]
fn corpus_areas_match_the_transformed_meshes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<std::path::PathBuf> = vec![
        root.join("tests/data/blender_room.glb"),
        root.join("tests/data/trimesh_scene.glb"),
    ];
    let mut dirs = vec![root.join("../shrad-scene/tests/data/khronos")];
    if let Some(extra) = std::env::var_os("SHRAD_EXTRA_MODELS") {
        dirs.push(extra.into());
    }
    for dir in dirs {
        let mut more: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "gltf" || x == "glb"))
            .collect();
        more.sort();
        files.extend(more);
    }
    for path in files {
        let scene = match shrad::scene::load(&path, &Default::default()) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{}: refused: {e}", path.display());
                continue;
            }
        };
        let world = World::new(scene, PatchSizing::Count(2000), Backend::Auto).unwrap();
        let mut worst = 0.0f64;
        let mut triangles = 0;
        for (o, object) in world.scene.objects.iter().enumerate() {
            let want = object.mesh.transformed(object.world_from_object).area() as f64;
            let sides = if object.material.double_sided {
                2.0
            } else {
                1.0
            };
            let ours: f64 = world
                .patches
                .range(o)
                .map(|p| world.patches.area[p] as f64)
                .sum::<f64>()
                / sides;
            worst = worst.max((ours - want).abs() / want);
            triangles += object.mesh.triangles.len();
        }
        eprintln!(
            "{}: {} objects, {triangles} triangles, {} patches, largest area difference {:.1e}",
            path.display(),
            world.scene.objects.len(),
            world.patches.len(),
            worst
        );
        assert!(worst < 1e-4, "{}: area differs by {worst}", path.display());
    }
}

/// trimesh's scene: each object's area is what trimesh measures, and every box, the
/// mirrored one included, faces out while the room faces in.
#[test]
fn trimesh_scene_areas_and_facing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/trimesh_scene.glb");
    let scene = shrad::scene::load(&path, &Default::default()).unwrap();
    let world = World::new(scene, PatchSizing::Size(0.1), Backend::Auto).unwrap();
    let p = &world.patches;
    for (name, area) in [("room", 94.0), ("box0", 0.54), ("box1", 7.0), ("box2", 1.6)] {
        let o = world
            .scene
            .objects
            .iter()
            .position(|o| o.name == name)
            .unwrap();
        let ours: f64 = p.range(o).map(|i| p.area[i] as f64).sum();
        assert!(
            (ours - area).abs() < 1e-4 * area,
            "{name}: {ours} vs trimesh's {area}"
        );
        let centre = world.scene.objects[o].world_bounds().unwrap().centre();
        let outward = p
            .range(o)
            .filter(|&i| p.normal[i].dot(p.centre[i] - centre) > 0.0)
            .count();
        let want = if name == "room" { 0 } else { p.range(o).len() };
        assert_eq!(outward, want, "{name}");
    }
}
