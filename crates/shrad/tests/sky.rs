//! The sky through every solver, against closed forms: a uniform sky of radiance `L` gives
//! an open upward floor `E = pi L`; a map bright in its upper half alone gives the same
//! floor `pi L` (the top row is +Y); a map with one bright texel gives the texel's own
//! integral `L dphi (sin^2 theta1 - sin^2 theta0) / 2`; a sky changed through the engine
//! equals the scene loaded with it; the map's centre column looks along +Z (Mitsuba's
//! `envmap`), and `rotate_deg` turns it counter-clockwise seen from above.

use crate::common;

use std::f32::consts::PI;
use std::path::PathBuf;

use glam::Vec3;
use shrad::engine::Engine;
use shrad::render::{RenderOptions, Shading};
use shrad::solver::SolverChoice;
use shrad::PatchSizing;
use shrad_scene::{Camera, EnvMap, Environment, Material, Object, Role, Scene};
use shrad_vis::Backend;

const HALF: f32 = 2.0;
const RHO: f32 = 0.5;

/// A floor of half-width [`HALF`] facing +Y under `environment`, nothing else.
fn scene(environment: Environment) -> Scene {
    let floor = common::floor(HALF);
    Scene {
        source: "floor-under-sky".into(),
        objects: vec![Object {
            role: Some(Role::Boundary),
            ..Object::new("floor", floor, Material::diffuse(Vec3::splat(RHO)))
        }],
        environment: Some(environment),
        ..Default::default()
    }
}

fn solvers() -> Vec<(&'static str, SolverChoice)> {
    let mut out = vec![(
        "reference",
        SolverChoice::preset("reference", "fast").unwrap(),
    )];
    for preset in shrad::settings::presets("dispersive").unwrap() {
        let name: &'static str = Box::leak(format!("dispersive {preset}").into_boxed_str());
        out.push((name, SolverChoice::preset("dispersive", preset).unwrap()));
    }
    out.push(("grid", SolverChoice::preset("grid", "paper4").unwrap()));
    out
}

/// The floor's irradiance per patch (its radiosity over `rho`) in `solver`.
fn floor_irradiance(s: &Scene, choice: SolverChoice) -> (Vec<Vec3>, f64) {
    let mut e = Engine::new(s.clone(), PatchSizing::Count(1000), Backend::Auto, choice).unwrap();
    let stats = e.converge(2);
    let input = stats.last().unwrap().energy.punctual;
    (e.radiosity().iter().map(|b| *b / RHO).collect(), input)
}

fn map(name: &str, width: u32, height: u32, texel: impl Fn(u32, u32) -> Vec3) -> EnvMap {
    let texels = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| texel(x, y))
        .collect();
    EnvMap::new(PathBuf::from(name), width, height, texels).unwrap()
}

/// Every patch of an open upward floor under a uniform sky takes `pi L` (cosine sampling is
/// exact there), in every solver and preset; the meter counts `pi L` times the area as input,
/// and what the floor reflects all leaves through the opening: absorbed + escaped = emitted.
#[test]
fn a_uniform_sky_gives_an_open_floor_pi_l() {
    let l = Vec3::new(1.0, 0.5, 0.25);
    let s = scene(Environment::uniform(l));
    let area = (2.0 * HALF as f64).powi(2);
    for (name, choice) in solvers() {
        let (e, input) = floor_irradiance(&s, choice);
        let mut engine =
            Engine::new(s.clone(), PatchSizing::Count(1000), Backend::Auto, choice).unwrap();
        let last = engine.converge(2).pop().unwrap().energy;
        let escaped = shrad::energy::escaped(engine.world(), engine.radiosity(), 16);
        assert!(
            ((last.absorbed + escaped) / last.emitted - 1.0).abs() < 1e-3
                && (escaped / last.emitted - RHO as f64).abs() < 1e-3,
            "{name}: emitted {}, absorbed {}, escaped {escaped}",
            last.emitted,
            last.absorbed
        );
        for (i, v) in e.iter().enumerate() {
            assert!(
                (*v - PI * l).abs().max_element() < 1e-4,
                "{name}: patch {i} takes {v}, closed form {}",
                PI * l
            );
        }
        let expected = PI as f64 * l.element_sum() as f64 / 3.0 * area;
        assert!(
            (input / expected - 1.0).abs() < 1e-3,
            "{name}: the meter counts {input}, closed form {expected}"
        );
    }
}

/// A map whose upper half is `L` and lower half black lights the floor as the uniform sky
/// `L` does (the map's top row is +Y), whatever its rotation and scaled by `scale`; upside
/// down (the bright half below) it leaves the floor dark.
#[test]
fn a_map_bright_above_the_horizon_gives_the_floor_pi_l() {
    let l = Vec3::new(0.8, 0.6, 0.4);
    let up = map("up.exr", 64, 32, |_, y| if y < 16 { l } else { Vec3::ZERO });
    let mut env = Environment::from_map(up);
    env.rotate_deg = 37.0;
    env.scale = 2.0;
    for (name, choice) in solvers() {
        let (e, _) = floor_irradiance(&scene(env.clone()), choice);
        let mean = e.iter().sum::<Vec3>() / e.len() as f32;
        let worst = e
            .iter()
            .map(|v| ((*v - 2.0 * PI * l) / (2.0 * PI * l)).abs().max_element())
            .fold(0.0, f32::max);
        assert!(
            ((mean - 2.0 * PI * l) / (2.0 * PI * l)).abs().max_element() < 0.01 && worst < 0.1,
            "{name}: mean {mean}, worst patch {worst}, closed form {}",
            2.0 * PI * l
        );
    }
    let down = map(
        "down.exr",
        64,
        32,
        |_, y| if y >= 16 { l } else { Vec3::ZERO },
    );
    let (e, _) = floor_irradiance(
        &scene(Environment::from_map(down)),
        SolverChoice::preset("reference", "fast").unwrap(),
    );
    assert!(e.iter().all(|v| v.max_element() < 1e-6));
}

/// One bright texel `(x, y)` of a black map is a small source: its irradiance on the floor
/// is `L dphi (sin^2 theta1 - sin^2 theta0) / 2` (`theta` from +Y, the floor's normal): the
/// floor's mean within 1 %, each patch (a few samples in the texel each) within 25 %.
#[test]
fn a_single_bright_texel_lights_like_a_small_source() {
    let (w, h, tx, ty) = (64u32, 32u32, 9u32, 6u32);
    let t = Vec3::new(500.0, 400.0, 300.0);
    let m = map("sun.hdr", w, h, |x, y| {
        if (x, y) == (tx, ty) {
            t
        } else {
            Vec3::ZERO
        }
    });
    let (t0, t1) = (PI * ty as f32 / h as f32, PI * (ty + 1) as f32 / h as f32);
    let closed = t * (2.0 * PI / w as f32) * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
    for (name, choice) in solvers() {
        let (e, _) = floor_irradiance(&scene(Environment::from_map(m.clone())), choice);
        let mean = e.iter().sum::<Vec3>() / e.len() as f32;
        let worst = e
            .iter()
            .map(|v| ((*v - closed) / closed).abs().max_element())
            .fold(0.0, f32::max);
        assert!(
            ((mean - closed) / closed).abs().max_element() < 0.01 && worst < 0.25,
            "{name}: mean {mean}, worst patch {worst}, closed form {closed}"
        );
    }
}

/// A sky set through the engine equals the scene loaded with it (the reference exactly, the
/// dispersive default once converged), and pictures show it where rays leave the scene.
#[test]
fn a_sky_set_through_the_engine_equals_the_scene_loaded_with_it() {
    let l = Vec3::new(0.3, 0.4, 0.5);
    for (name, choice) in [
        (
            "reference",
            SolverChoice::preset("reference", "fast").unwrap(),
        ),
        (
            "dispersive default",
            SolverChoice::preset("dispersive", "default").unwrap(),
        ),
    ] {
        let mut set = Engine::new(
            scene(Environment::uniform(Vec3::ONE)),
            PatchSizing::Count(500),
            Backend::Auto,
            choice,
        )
        .unwrap();
        set.converge(2);
        set.set_sky(Some(Environment::uniform(l))).unwrap();
        set.converge(2);
        let mut loaded = Engine::new(
            scene(Environment::uniform(l)),
            PatchSizing::Count(500),
            Backend::Auto,
            choice,
        )
        .unwrap();
        loaded.converge(2);
        let worst = set
            .radiosity()
            .iter()
            .zip(loaded.radiosity())
            .map(|(a, b)| (*a - *b).abs().max_element())
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{name}: {worst}");
        assert!(set
            .set_sky(Some(Environment::uniform(Vec3::new(-1.0, 0.0, 0.0))))
            .is_err());
        // Looking up from above the floor: all sky.
        let camera = Camera::look_at(Vec3::Y, Vec3::new(0.0, 2.0, 0.1), 0.5);
        let options = RenderOptions {
            width: 8,
            height: 8,
            spp: 1,
            shading: Shading::Smooth,
        };
        let img = set.render(Some(&camera), &options).unwrap();
        assert!(img
            .pixels
            .iter()
            .all(|p| (*p - l).abs().max_element() < 1e-5));
    }
}

/// The map's orientation, as Mitsuba 3's `envmap` reads it (checked against Mitsuba and
/// Blender by `validation/env_orientation.py`): the top row is +Y, the centre column looks
/// along +Z, the left and right edges (the seam) along -Z, u = 1/4 along +X; `rotate_deg`
/// turns the map counter-clockwise seen from above, so `rotate_deg = 90` puts the centre
/// column along +X, where Blender's Environment Texture has it.
#[test]
fn the_map_s_centre_column_looks_along_plus_z() {
    use shrad::sky::Sky;
    // 5 columns (an odd count: a centre column) x 3 rows, each texel its own colour.
    let m = map("columns.exr", 5, 3, |x, y| {
        Vec3::new(x as f32, y as f32, 1.0)
    });
    let look = |sky: &Sky, d: Vec3| {
        let t = sky.radiance(d.normalize());
        (t.x as u32, t.y as u32)
    };
    let sky = Sky::new(&Environment::from_map(m.clone()));
    // (column, row) seen along each direction, 20 degrees above the horizon: the middle row.
    let up = 20f32.to_radians().tan();
    for (name, d, column) in [
        ("+Z", Vec3::new(0.0, up, 1.0), 2),
        ("+X", Vec3::new(1.0, up, 0.0), 1),
        ("-X", Vec3::new(-1.0, up, 0.0), 3),
        ("-Z, a little towards +X", Vec3::new(0.1, up, -1.0), 0),
        ("-Z, a little towards -X", Vec3::new(-0.1, up, -1.0), 4),
    ] {
        assert_eq!(look(&sky, d), (column, 1), "looking along {name}");
    }
    assert_eq!(
        look(&sky, Vec3::new(0.0, 1.0, 0.01)).1,
        0,
        "up: the top row"
    );
    assert_eq!(
        look(&sky, Vec3::new(0.0, -1.0, 0.01)).1,
        2,
        "down: the bottom row"
    );
    let turned = Sky::new(&Environment {
        rotate_deg: 90.0,
        ..Environment::from_map(m)
    });
    assert_eq!(
        look(&turned, Vec3::new(1.0, up, 0.0)),
        (2, 1),
        "turned 90: +X"
    );
    assert_eq!(
        look(&turned, Vec3::new(0.0, up, 1.0)),
        (3, 1),
        "turned 90: +Z"
    );
}
