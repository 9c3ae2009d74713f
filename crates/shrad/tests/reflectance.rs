//! A surface painted another colour while the engine runs: every solver ends where a fresh
//! one on the scene loaded with that colour ends (Cornell's red wall painted blue; a black
//! box under a lamp painted white, whose patches only then receive the lamp's light; the
//! Cornell box's black light painted white, which only then reflects), and an absurd colour
//! is refused naming the object.

use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::solver::SolverChoice;
use shrad::PatchSizing;
use shrad_scene::{box_mesh, cornell_box, Light, LightKind, Material, Object, Role, Scene};
use shrad_vis::Backend;

use crate::common::{self, largest_difference};

fn solvers() -> Vec<(&'static str, SolverChoice)> {
    [
        ("reference", "fast"),
        ("dispersive", "paper"),
        ("dispersive", "default"),
        ("grid", "paper4"),
    ]
    .into_iter()
    .map(|(s, p)| (p, SolverChoice::preset(s, p).unwrap()))
    .map(|(p, c)| (if p == "fast" { "reference" } else { p }, c))
    .collect()
}

/// Object `name` of `scene`.
fn named(scene: &Scene, name: &str) -> usize {
    (scene.objects.iter())
        .position(|o| o.name == name)
        .unwrap_or_else(|| panic!("no object {name}"))
}

/// How the engine is told of the new colour: `set_reflectance`, or a time at which the
/// object's keyed base colour is it.
#[derive(Clone, Copy)]
enum Paint {
    Set(Vec3),
    AtTime(f32),
}

/// `scene` converged, then object `o` painted (`paint`) and converged again, against a fresh
/// engine on `painted` (the scene with that colour), for each solver: within `1e-5` of the
/// largest radiosity for the reference, the grid and the dispersive solvers within
/// `tolerance` of it; and it did change.
fn painted_equals_loaded(scene: &Scene, painted: &Scene, o: usize, paint: Paint, tolerance: f32) {
    for (name, choice) in solvers() {
        let make = |s: &Scene| {
            Engine::new(s.clone(), PatchSizing::Count(2000), Backend::Auto, choice).unwrap()
        };
        let mut engine = make(scene);
        engine.converge(2);
        let before = engine.radiosity().to_vec();
        match paint {
            Paint::Set(rho) => engine.set_reflectance(o, rho).unwrap(),
            Paint::AtTime(t) => engine.set_time(t).unwrap(),
        }
        engine.converge(4);
        let mut fresh = make(painted);
        fresh.converge(6);
        let (worst, top) = largest_difference(engine.radiosity(), fresh.radiosity());
        let tolerance = if name == "reference" { 1e-5 } else { tolerance };
        assert!(worst <= tolerance * top, "{name}: {worst} of {top}");
        // The light the painted object reflects (its emission aside, which can hide it: a
        // light's) is the fresh engine's too, and it did change where that one says it should.
        let r = engine.world().patches.range(o);
        let reflected = |b: &[Vec3]| -> Vec<Vec3> {
            let e = &engine.world().exitance;
            r.clone().map(|i| b[i] - e[i]).collect()
        };
        let (now, was) = (reflected(engine.radiosity()), reflected(&before));
        let (worst, top) = largest_difference(&now, &reflected(fresh.radiosity()));
        assert!(
            worst <= tolerance * top,
            "{name}: painted object {worst} of {top}"
        );
        let (changed, _) = largest_difference(&now, &was);
        assert!(changed > 0.2 * top, "{name}: changed by {changed} of {top}");
    }
}

#[test]
fn cornells_red_wall_painted_blue_equals_the_box_loaded_blue() {
    let scene = cornell_box();
    let wall = named(&scene, "left_red");
    let blue = Vec3::new(0.1, 0.2, 0.7);
    let mut painted = scene.clone();
    painted.objects[wall].material.reflectance = blue;
    painted_equals_loaded(&scene, &painted, wall, Paint::Set(blue), 0.02);
}

#[test]
fn a_keyed_base_colour_plays_through_the_engine() {
    // The red wall's base colour keyed from red to blue over 2 s (as a glTF file's
    // KHR_animation_pointer channel gives it): at t = 1.5 it is what the box loaded with
    // the colour of that time gives.
    let mut scene = cornell_box();
    let wall = named(&scene, "left_red");
    let red = scene.objects[wall].material.reflectance;
    let blue = Vec3::new(0.1, 0.2, 0.7);
    scene.objects[wall].material_tracks = Some(shrad_scene::MaterialTracks {
        base_color: Some(shrad_scene::Track {
            times: vec![0.0, 2.0],
            values: vec![red, blue],
            interpolation: shrad_scene::Interpolation::Linear,
        }),
        ..Default::default()
    });
    let mut painted = cornell_box();
    painted.objects[wall].material.reflectance = red.lerp(blue, 0.75);
    painted_equals_loaded(&scene, &painted, wall, Paint::AtTime(1.5), 0.02);
}

/// A floor under a point light, and a box on it of reflectance `rho` (black: 0).
fn box_under_a_lamp(rho: f32) -> Scene {
    Scene {
        source: "box-under-a-lamp".into(),
        objects: vec![
            Object {
                role: Some(Role::Boundary),
                ..Object::new(
                    "floor",
                    common::floor(2.0),
                    Material::diffuse(Vec3::splat(0.5)),
                )
            },
            Object {
                role: Some(Role::Interior),
                world_from_object: Affine3A::from_translation(Vec3::new(0.3, 0.25, -0.2)),
                ..Object::new(
                    "box",
                    box_mesh(Vec3::splat(0.25), false),
                    Material::diffuse(Vec3::splat(rho)),
                )
            },
        ],
        lights: vec![Light {
            world_from_light: Affine3A::from_translation(Vec3::new(-0.6, 1.4, 0.3)),
            ..Light::new("bulb", LightKind::Point, 683.0)
        }],
        ..Default::default()
    }
}

#[test]
fn a_black_box_painted_white_takes_the_lamps_light() {
    // A black patch reflects nothing, so the solvers' caches of the lamp's direct light
    // leave it out; painted, it must be lit as a box loaded white is.
    let white = Vec3::splat(0.8);
    let (black, loaded) = (box_under_a_lamp(0.0), box_under_a_lamp(0.8));
    painted_equals_loaded(&black, &loaded, 1, Paint::Set(white), 0.02);
}

#[test]
fn an_absurd_colour_is_refused_naming_the_object() {
    let mut engine = Engine::new(
        cornell_box(),
        PatchSizing::Count(500),
        Backend::Auto,
        SolverChoice::preset("dispersive", "default").unwrap(),
    )
    .unwrap();
    for bad in [
        Vec3::new(f32::NAN, 0.5, 0.5),
        Vec3::new(-0.1, 0.5, 0.5),
        Vec3::new(0.5, 1.5, 0.5),
        Vec3::splat(f32::INFINITY),
    ] {
        let e = engine.set_reflectance(0, bad).unwrap_err().to_string();
        assert!(
            e.contains("object 0") && e.contains("reflectance"),
            "{bad}: {e}"
        );
    }
    let e = engine
        .set_reflectance(99, Vec3::splat(0.5))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no object 99"), "{e}");
    // 1 is allowed, and read as the largest reflectance that conserves energy.
    engine.set_reflectance(0, Vec3::ONE).unwrap();
    let rho = engine.world().reflectance[engine.world().patches.range(0)][0];
    assert_eq!(rho, Vec3::splat(shrad::surface::MAX_REFLECTANCE));
}

/// The Cornell box as a scene file whose red wall is keyed from red to blue over 2 s
/// (`reflectance_keys`: the `[[object.reflectance_key]]` tables).
fn keyed_wall_toml(reflectance_keys: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("shrad-reflectance-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("wall-{}.toml", reflectance_keys.len()));
    let text = format!(
        r#"
[[object]]
name = "floor"
role = "boundary"
shape = "quad"
corners = [[0, 0, 0], [0, 0, 2], [2, 0, 2], [2, 0, 0]]
reflectance = [0.7, 0.7, 0.7]

[[object]]
name = "lamp"
role = "light"
shape = "quad"
corners = [[0.8, 1.9, 0.8], [1.2, 1.9, 0.8], [1.2, 1.9, 1.2], [0.8, 1.9, 1.2]]
reflectance = [0, 0, 0]
emission = [10, 10, 10]

[[object]]
name = "wall"
role = "boundary"
shape = "quad"
corners = [[0, 0, 0], [0, 2, 0], [0, 2, 2], [0, 0, 2]]
reflectance = [0.6, 0.1, 0.1]
{reflectance_keys}
"#
    );
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_scene_files_reflectance_keys_play_and_bad_ones_are_refused() {
    let keys = "[[object.reflectance_key]]\ntime = 0\nreflectance = [0.6, 0.1, 0.1]\n\
                [[object.reflectance_key]]\ntime = 2\nreflectance = [0.1, 0.2, 1.0]\n";
    let scene = shrad_scene::load(&keyed_wall_toml(keys), &Default::default()).unwrap();
    let wall = named(&scene, "wall");
    assert!(scene.objects[wall].is_animated());
    assert_eq!(scene.objects[wall].duration(), 2.0);
    let mut engine = Engine::new(
        scene,
        PatchSizing::Count(300),
        Backend::Auto,
        SolverChoice::preset("dispersive", "default").unwrap(),
    )
    .unwrap();
    // Linear between the keys; a key of 1 is read as the largest reflectance.
    let top = shrad::surface::MAX_REFLECTANCE;
    for (t, want) in [
        (0.5, Vec3::new(0.475, 0.125, 0.325)),
        (2.5, Vec3::new(0.1, 0.2, top)),
    ] {
        engine.set_time(t).unwrap();
        let w = engine.world();
        for i in w.patches.range(wall) {
            assert!(
                w.reflectance[i].abs_diff_eq(want, 1e-6),
                "t {t}: {}",
                w.reflectance[i]
            );
        }
    }
    for bad in ["[1.5, 0, 0]", "[-0.1, 0, 0]", "[nan, 0, 0]"] {
        let keys = format!("[[object.reflectance_key]]\ntime = 1\nreflectance = {bad}\n");
        let e = shrad_scene::load(&keyed_wall_toml(&keys), &Default::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("reflectance_key 0"), "{bad}: {e}");
    }
}

#[test]
fn cornells_black_light_painted_white_equals_the_box_loaded_with_a_white_light() {
    // The light reflects nothing when loaded; painted, it reflects what reaches it as the
    // walls do (each solver's exchange among the boundary's patches takes it in).
    let scene = cornell_box();
    let light = named(&scene, "light");
    let white = Vec3::splat(0.8);
    let mut painted = scene.clone();
    painted.objects[light].material.reflectance = white;
    painted_equals_loaded(&scene, &painted, light, Paint::Set(white), 0.02);
}
