//! `shrad::bake`: the light per vertex in a glTF, a sequence all or nothing, and bad paths
//! as errors.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use glam::Vec3;
use shrad::bake::{bake, bake_with_progress, frame_path, write_gltf, BakeOptions};
use shrad::engine::Engine;
use shrad::scene::staged_path;
use shrad::solver::SolverChoice;
use shrad::PatchSizing;

fn engine() -> Engine {
    let mut e = Engine::new(
        shrad::scene::cornell_box(),
        PatchSizing::Count(600),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    e.step();
    e
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-bake-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn the_glb_holds_the_light_per_vertex() {
    let e = engine();
    let d = dir("glb");
    let path = d.join("cornell.glb");
    let baked = write_gltf(&e, &path, Some(2.0)).unwrap();
    assert_eq!(baked.meshes, e.world().scene.objects.len());
    let (doc, buffers, _) = gltf::import(&path).unwrap();
    assert_eq!(
        doc.extensions_used().collect::<Vec<_>>(),
        ["KHR_materials_unlit"]
    );
    let mut vertices = 0;
    let mut sum_b = Vec3::ZERO;
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let r = prim.reader(|b| Some(&buffers[b.index()]));
            let pos: Vec<[f32; 3]> = r.read_positions().unwrap().collect();
            let colours: Vec<[f32; 3]> = r.read_colors(0).unwrap().into_rgb_f32().collect();
            assert_eq!(pos.len(), colours.len());
            assert!(colours.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
            let radiosity = prim
                .attributes()
                .find(|(s, _)| *s == gltf::Semantic::Extras("RADIOSITY".into()))
                .map(|(_, a)| a)
                .expect("_RADIOSITY");
            assert_eq!(radiosity.count(), pos.len());
            let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
            assert!(idx.iter().all(|&i| (i as usize) < pos.len()));
            vertices += pos.len();
            let view = radiosity.view().unwrap();
            let bytes =
                &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
            for c in bytes.chunks_exact(12) {
                let f = |k: usize| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap());
                sum_b += Vec3::new(f(0), f(1), f(2));
            }
        }
    }
    assert_eq!(vertices, baked.vertices);
    // Every shading vertex once, with the engine's radiosity there.
    assert_eq!(vertices, e.world().patches.shading_vertex_count);
    let want: Vec3 = e.vertex_colors().iter().sum();
    assert!(
        (sum_b - want).length() <= 1e-4 * want.length(),
        "{sum_b} vs {want}"
    );
}

/// The Cornell box with its short block sliding along +x over one second.
fn animated_engine() -> Engine {
    use shrad::scene::{Animation, Keyframe};
    let mut scene = shrad::scene::cornell_box();
    let block = scene
        .objects
        .iter_mut()
        .find(|o| o.name == "short_block")
        .unwrap();
    let key = |time, x| Keyframe {
        time,
        translation: Vec3::new(x, 0.0, 0.0),
        rotation: glam::Quat::IDENTITY,
    };
    block.animation = Some(Animation {
        keys: vec![key(0.0, 0.0), key(1.0, 60.0)],
        ..Default::default()
    });
    Engine::new(
        scene,
        PatchSizing::Count(400),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap()
}

fn entries(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn a_sequence_that_fails_partway_leaves_no_file_of_it() {
    let mut e = animated_engine();
    assert!(e.world().scene.duration() > 0.0);
    let d = dir("partway");
    let path = d.join("out.glb");
    let options = BakeOptions {
        frames: Some(3),
        passes: 1,
        ..Default::default()
    };
    // Frame 1 cannot be written: a folder holds its staged name.
    let blocker = staged_path(&frame_path(&path, 1));
    std::fs::create_dir(&blocker).unwrap();
    let err = bake(&mut e, &path, &options).unwrap_err().to_string();
    assert!(err.contains("out_0001.glb"), "{err}");
    let blocker_name = blocker.file_name().unwrap().to_string_lossy().into_owned();
    assert_eq!(entries(&d), [blocker_name], "frame 0 was left behind");
    std::fs::remove_dir(&blocker).unwrap();

    // Frame 2 cannot be renamed into place (a folder has its name): frames 0 and 1,
    // renamed already, are removed again.
    let last = frame_path(&path, 2);
    std::fs::create_dir(&last).unwrap();
    let err = bake(&mut e, &path, &options).unwrap_err().to_string();
    assert!(err.contains("out_0002.glb"), "{err}");
    assert_eq!(entries(&d), ["out_0002.glb"], "part of the sequence stayed");
    std::fs::remove_dir(&last).unwrap();

    // Nothing in the way: the whole sequence, and no staged file.
    let baked = bake(&mut e, &path, &options).unwrap();
    assert_eq!(baked.len(), 3);
    assert_eq!(
        entries(&d),
        ["out_0000.glb", "out_0001.glb", "out_0002.glb"]
    );
    assert!(gltf::import(frame_path(&path, 2)).is_ok());
}

/// Asks to stop once `after` units of work are done (a front end's Ctrl-C).
struct StopAfter {
    after: u64,
    done: AtomicU64,
}

impl shrad::Progress for StopAfter {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, n: u64) {
        self.done.fetch_add(n, Relaxed);
    }
    fn end(&self) {}
    fn stop_requested(&self) -> bool {
        self.done.load(Relaxed) >= self.after
    }
}

#[test]
fn a_bake_asked_to_stop_is_interrupted_and_writes_nothing() {
    let d = dir("stop");
    let path = d.join("out.glb");
    let options = BakeOptions {
        frames: Some(3),
        passes: 1,
        ..Default::default()
    };
    // The reference: within the first file's solve (after its direct light).
    let mut e = animated_engine();
    let stop = StopAfter {
        after: 1,
        done: AtomicU64::new(0),
    };
    let err = bake_with_progress(&mut e, &path, &options, &stop).unwrap_err();
    assert!(matches!(err, shrad::Error::Interrupted), "{err}");
    assert_eq!(err.to_string(), "interrupted");
    assert_eq!(e.frames(), 0);
    // The dispersive solver: its frames between files; the first file was staged.
    let mut e = Engine::from_world(
        e.into_world(),
        SolverChoice::preset("dispersive", "default").unwrap(),
    )
    .unwrap();
    let stop = StopAfter {
        after: 1,
        done: AtomicU64::new(0),
    };
    let err = bake_with_progress(&mut e, &path, &options, &stop).unwrap_err();
    assert!(matches!(err, shrad::Error::Interrupted), "{err}");
    assert_eq!(stop.done.load(Relaxed), 1, "one file staged");
    assert!(entries(&d).is_empty(), "{:?}", entries(&d));
    // The engine is whole: a bake without the stop writes the sequence.
    assert_eq!(bake(&mut e, &path, &options).unwrap().len(), 3);
}

#[test]
fn gltf_with_bin_and_bad_paths() {
    let mut e = engine();
    let d = dir("gltf");
    let path = d.join("c.gltf");
    let frames = e.frames();
    let baked = bake(
        &mut e,
        &path,
        &BakeOptions {
            passes: 0,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(
        e.frames(),
        frames,
        "0 passes: the state as it is, not solved again"
    );
    assert!(d.join("c.bin").is_file() && baked[0].exposure > 0.0);
    assert!(gltf::import(&path).is_ok());
    let err = write_gltf(&e, &d.join("c.png"), None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("c.png") && err.contains(".glb"), "{err}");
    let err = write_gltf(&e, &d.join("no/such/dir/c.glb"), None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("does not exist"), "{err}");
    let static_frames = BakeOptions {
        frames: Some(3),
        ..Default::default()
    };
    assert!(bake(&mut e, &path, &static_frames)
        .unwrap_err()
        .to_string()
        .contains("not animated"));
    assert!(write_gltf(&e, &path, Some(f32::NAN)).is_err());
    assert_eq!(
        frame_path(Path::new("a/out.glb"), 7),
        Path::new("a/out_0007.glb")
    );
}

/// A bake or export over the file the engine's scene was read from is refused, before any
/// solve, and the scene file is left as it was: the engine that loaded `room.glb` baked
/// over it.
#[test]
fn a_bake_over_the_scene_file_being_read_is_refused_and_leaves_it_whole() {
    let d = dir("over-scene");
    let scene_file = d.join("cornell.glb");
    shrad::scene::write_gltf(&shrad::scene::cornell_box(), &scene_file).unwrap();
    let before = std::fs::read(&scene_file).unwrap();
    let scene = shrad::scene::load(&scene_file, &Default::default()).unwrap();
    let mut e = Engine::new(
        scene,
        PatchSizing::Count(600),
        shrad::vis::Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    // The same file named through another spelling of its folder.
    let spelled = d.join(".").join("cornell.glb");
    for path in [&scene_file, &spelled] {
        let message = bake(&mut e, path, &BakeOptions::default())
            .unwrap_err()
            .to_string();
        assert!(message.contains("the scene file being read"), "{message}");
        let message = write_gltf(&e, path, None).unwrap_err().to_string();
        assert!(message.contains("the scene file being read"), "{message}");
    }
    assert_eq!(e.frames(), 0, "the bake solved before it refused");
    assert_eq!(std::fs::read(&scene_file).unwrap(), before);
    // Another name beside it is written.
    bake(&mut e, &d.join("baked.glb"), &BakeOptions::default()).unwrap();
    assert_eq!(std::fs::read(&scene_file).unwrap(), before);
}
