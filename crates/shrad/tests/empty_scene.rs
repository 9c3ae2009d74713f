//! A scene with nothing to light (a valid glTF whose triangles all have zero area, or whose
//! data is not in the file, loads empty) goes through the one engine like any other: every
//! solver and preset steps it, its pictures are the background, the viewer's data of it is
//! empty, and a bake of it is refused saying why; nothing panics.

use glam::{Affine3A, Vec3};
use shrad::bake::{bake, BakeOptions};
use shrad::engine::Engine;
use shrad::render::{RenderOptions, Shading};
use shrad::scene::{Environment, Light, LightKind, Scene};
use shrad::solver::SolverChoice;
use shrad::view_data::{channel_radiosity, direct_irradiance, probes, Channel, DisplayMesh};
use shrad::vis::Backend;
use shrad::PatchSizing;

/// No object; a point light (which has nothing to light) and, when `sky`, a uniform sky.
fn empty(sky: Option<Vec3>) -> Scene {
    let mut light = Light::new("lamp", LightKind::Point, 100.0);
    light.world_from_light = Affine3A::from_translation(Vec3::new(0.0, 2.0, 0.0));
    Scene {
        source: "empty.gltf".into(),
        lights: vec![light],
        environment: sky.map(Environment::uniform),
        ..Default::default()
    }
}

fn picture(e: &Engine, shading: Shading) -> Vec<Vec3> {
    let options = RenderOptions {
        width: 12,
        height: 8,
        spp: 2,
        shading,
    };
    let image = e.render(None, &options).unwrap();
    assert_eq!(image.pixels.len(), 96);
    assert!(image.emitter.iter().all(|&x| !x));
    image.pixels
}

/// Everything a front end asks of an engine, on an empty scene.
fn exercise(mut e: Engine, background: Vec3, what: &str) {
    assert_eq!(e.world().patches.len(), 0, "{what}");
    for _ in 0..3 {
        let stats = e.step();
        assert!(stats.objects_updated.is_empty(), "{what}");
        assert!(stats.diverged.is_none(), "{what}");
    }
    e.converge(2);
    e.step_within(5.0).unwrap();
    e.set_time(1.5).unwrap();
    e.step();
    assert!(e.radiosity().is_empty(), "{what}");
    assert!(e.vertex_colors().is_empty(), "{what}");
    assert!(e.roles().is_empty(), "{what}");
    for shading in [Shading::Smooth, Shading::Flat] {
        for p in picture(&e, shading) {
            assert!(
                (p - background).abs().max_element() <= 1e-5 * (1.0 + background.max_element()),
                "{what}: {p} is not the background {background}"
            );
        }
    }
    // No patch: the error has nothing to measure (NaN, never a panic).
    let error = e.error();
    assert!(
        error.overall.is_nan() && error.boundary.is_nan() && error.interior.is_nan(),
        "{what}: {error:?}"
    );
    // No object to move or light; the light can still be moved.
    assert!(e.object("anything").is_err(), "{what}");
    assert!(e.set_transform(0, Affine3A::IDENTITY).is_err(), "{what}");
    assert!(e.set_emission(0, Vec3::ONE).is_err(), "{what}");
    let l = e.light("lamp").unwrap();
    e.set_light(l, Affine3A::from_translation(Vec3::Y), Vec3::ONE, 10.0)
        .unwrap();
    e.step();
    // What the viewer draws: an empty mesh, empty channels.
    let mesh = DisplayMesh::new(e.world());
    assert_eq!(mesh.vertex_count(), 0, "{what}");
    let direct = direct_irradiance(&e, 4).into_owned();
    assert!(direct.is_empty(), "{what}");
    for channel in [Channel::Total, Channel::Direct, Channel::Indirect] {
        assert!(channel_radiosity(&e, channel, &direct).is_empty(), "{what}");
    }
    if let Some(p) = probes(&e) {
        assert!(p.is_empty(), "{what}");
    }
    // Nothing to bake: refused before any file is written.
    let out = std::env::temp_dir().join(format!("shrad-empty-{}-{what}.glb", std::process::id()));
    let msg = bake(&mut e, &out, &BakeOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("empty.gltf") && msg.contains("nothing to bake"),
        "{what}: {msg}"
    );
    let msg = shrad::bake::write_gltf(&e, &out, None)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("nothing to bake"), "{what}: {msg}");
    assert!(!out.exists(), "{what}");
}

#[test]
fn an_empty_scene_steps_renders_the_background_and_never_panics() {
    for solver in ["reference", "dispersive", "grid"] {
        for &preset in shrad::settings::presets(solver).unwrap() {
            let what = format!("{solver}-{preset}");
            let choice = SolverChoice::preset(solver, preset).unwrap();
            let e = Engine::new(empty(None), PatchSizing::Count(500), Backend::Auto, choice)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            exercise(e, Vec3::ZERO, &what);
        }
    }
}

#[test]
fn an_empty_scene_shows_its_sky_on_either_backend() {
    // A uniform sky of radiance L: a ray that leaves the scene sees L (the picture is
    // radiance).
    let sky = Vec3::new(0.2, 0.3, 0.4);
    for backend in [Backend::Bvh, Backend::Auto] {
        for solver in ["reference", "dispersive", "grid"] {
            let what = format!("{backend:?}-{solver}-sky");
            let choice = SolverChoice::preset(solver, "default").unwrap();
            let e = Engine::new(empty(Some(sky)), PatchSizing::Size(0.1), backend, choice)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            exercise(e, sky, &what);
        }
    }
}
