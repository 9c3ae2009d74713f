//! Punctual lights through every solver and the engine: a floor under a point light
//! reflects `rho` times the flux the closed form gives, whichever solver runs; the energy
//! meter counts what reaches the patches as input; a light moved through the engine gives
//! what the same scene loaded with the light there gives; a picture's shadow edge is sharp.

use crate::common::{self, largest_difference};

use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::render::{RenderOptions, Shading};
use shrad::solver::SolverChoice;
use shrad::PatchSizing;
use shrad_scene::{box_mesh, Camera, Light, LightKind, Material, Object, Role, Scene};
use shrad_vis::Backend;

const HALF: f32 = 2.0;
const RHO: f32 = 0.5;

/// A floor of half-width [`HALF`] facing +Y, a box (half-size 0.25) on it at `box_at`, a
/// point light of 683 cd (1 W/sr) at `light_at`.
fn scene(light_at: Vec3, box_at: Vec3) -> Scene {
    let floor = common::floor(HALF);
    Scene {
        source: "floor-and-box".into(),
        objects: vec![
            Object {
                role: Some(Role::Boundary),
                ..Object::new("floor", floor, Material::diffuse(Vec3::splat(RHO)))
            },
            Object {
                role: Some(Role::Interior),
                world_from_object: Affine3A::from_translation(box_at),
                ..Object::new(
                    "box",
                    box_mesh(Vec3::splat(0.25), false),
                    Material::diffuse(Vec3::splat(RHO)),
                )
            },
        ],
        lights: vec![Light {
            world_from_light: Affine3A::from_translation(light_at),
            ..Light::new("bulb", LightKind::Point, 683.0)
        }],
        ..Default::default()
    }
}

fn solvers() -> Vec<(&'static str, SolverChoice)> {
    vec![
        (
            "reference",
            SolverChoice::preset("reference", "fast").unwrap(),
        ),
        (
            "dispersive paper",
            SolverChoice::preset("dispersive", "paper").unwrap(),
        ),
        (
            "dispersive default",
            SolverChoice::preset("dispersive", "default").unwrap(),
        ),
        ("grid", SolverChoice::preset("grid", "paper4").unwrap()),
    ]
}

/// With the box far outside the light's reach (below the floor, which it cannot light:
/// the floor's back), the floor's reflected flux is `rho` times `I` times the solid angle
/// of the square from the light, in every solver; the meter counts that flux as input.
#[test]
fn every_solver_lights_a_floor_by_the_closed_form() {
    let h = 1.0;
    let s = scene(Vec3::Y * h, Vec3::new(0.0, -5.0, 0.0));
    let (a2, h2) = (HALF * HALF, h * h);
    let input = (4.0 * (a2 / (a2 + h2)).asin()) as f64;
    for (name, choice) in solvers() {
        let mut e =
            Engine::new(s.clone(), PatchSizing::Count(3000), Backend::Auto, choice).unwrap();
        let stats = e.converge(2);
        let last = stats.last().unwrap();
        let p = &e.world().patches;
        let b = e.radiosity();
        let reflected: f64 = p.range(0).map(|i| b[i].x as f64 * p.area[i] as f64).sum();
        let expected = RHO as f64 * input;
        assert!(
            (reflected / expected - 1.0).abs() < 0.01,
            "{name}: floor reflects {reflected}, closed form {expected}"
        );
        assert!(
            (last.energy.punctual / input - 1.0).abs() < 0.01,
            "{name}: meter's punctual input {} vs {input}",
            last.energy.punctual
        );
        assert!(last.energy.emitted >= last.energy.punctual && last.diverged.is_none());
    }
}

/// A light moved (and re-coloured) through the engine equals the scene loaded with the light
/// there, for the reference exactly and for the dispersive solver once converged.
#[test]
fn a_light_moved_through_the_engine_equals_the_scene_loaded_with_it_there() {
    let box_at = Vec3::new(0.3, 0.25, -0.2);
    let (from, to) = (Vec3::new(-1.0, 1.5, 0.5), Vec3::new(0.6, 1.2, 0.1));
    for (name, choice) in solvers() {
        let mut moved = Engine::new(
            scene(from, box_at),
            PatchSizing::Count(2000),
            Backend::Auto,
            choice,
        )
        .unwrap();
        moved.converge(2);
        let l = moved.light("bulb").unwrap();
        moved
            .set_light(
                l,
                Affine3A::from_translation(to),
                Vec3::new(1.0, 0.8, 0.6),
                683.0,
            )
            .unwrap();
        moved.converge(4);
        let mut there = scene(to, box_at);
        there.lights[0].color = Vec3::new(1.0, 0.8, 0.6);
        let mut loaded =
            Engine::new(there, PatchSizing::Count(2000), Backend::Auto, choice).unwrap();
        loaded.converge(4);
        let (worst, top) = largest_difference(moved.radiosity(), loaded.radiosity());
        let tolerance = if name == "reference" { 1e-6 } else { 0.02 };
        assert!(worst <= tolerance * top, "{name}: {worst} of {top}");
    }
    let mut e = Engine::new(
        scene(from, box_at),
        PatchSizing::Count(500),
        Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    assert!(e.light("lamp").unwrap_err().to_string().contains("bulb"));
    assert!(e
        .set_light(0, Affine3A::IDENTITY, Vec3::ONE, f32::NAN)
        .is_err());
}

/// A box dragged under the point light beside a second box, so that Step 2 lights it only
/// some frames (its own patches' punctual light is traced only when read, or once it
/// rests), then left still: the dispersive default ends where the scene loaded with the box
/// there converges.
#[test]
fn a_box_dragged_under_a_point_light_ends_where_the_scene_loaded_there_does() {
    let light = Vec3::new(0.2, 1.4, 0.1);
    let with_two = |box_at: Vec3| {
        let mut s = scene(light, box_at);
        let mut other = s.objects[1].clone();
        other.name = "other".into();
        other.world_from_object = Affine3A::from_translation(Vec3::new(-0.9, 0.25, 0.8));
        s.objects.push(other);
        s
    };
    let choice = SolverChoice::preset("dispersive", "default").unwrap();
    let engine = |box_at: Vec3| {
        Engine::new(
            with_two(box_at),
            PatchSizing::Count(3000),
            Backend::Auto,
            choice,
        )
        .unwrap()
    };
    let (start, end) = (Vec3::new(0.8, 0.25, -0.6), Vec3::new(-0.2, 0.25, 0.1));
    let mut e = engine(start);
    e.converge(2);
    let b = e.object("box").unwrap();
    let mut unlit = 0;
    for k in 1..=8 {
        let at = start + (end - start) * (k as f32 / 8.0);
        e.set_transform(b, Affine3A::from_translation(at)).unwrap();
        unlit += usize::from(!e.step().objects_updated.contains(&b));
    }
    assert!(
        unlit > 0,
        "the box was lit in every moving frame: nothing waited"
    );
    e.converge(6);
    let mut loaded = engine(end);
    loaded.converge(6);
    let (worst, top) = largest_difference(e.radiosity(), loaded.radiosity());
    assert!(worst <= 0.02 * top, "{worst} of {top}");
}

/// A track of `values` at times 0 and 2, linear.
fn ramp<T>(values: [T; 2]) -> shrad_scene::Track<T> {
    shrad_scene::Track {
        times: vec![0.0, 2.0],
        values: values.into(),
        interpolation: shrad_scene::Interpolation::Linear,
    }
}

#[test]
fn an_animated_light_and_glow_give_at_a_time_what_the_scene_with_their_values_then_gives() {
    let (light_at, box_at) = (Vec3::new(-0.5, 1.5, 0.3), Vec3::new(0.3, 0.25, -0.2));
    // The bulb's intensity and colour and the box's emission strength animated (as a glTF
    // file's KHR_animation_pointer channels give them), against the same scene made with
    // their values at t = 1.5 and nothing animated.
    let mut animated = scene(light_at, box_at);
    animated.lights[0].tracks = Some(shrad_scene::LightTracks {
        intensity: Some(ramp([683.0, 2.0 * 683.0])),
        color: Some(ramp([Vec3::ONE, Vec3::new(1.0, 0.6, 0.2)])),
        ..Default::default()
    });
    animated.objects[1].material_tracks = Some(shrad_scene::MaterialTracks {
        rest_factor: Vec3::new(0.2, 0.1, 0.05),
        rest_strength: 1.0,
        factor: None,
        strength: Some(ramp([0.0, 4.0])),
        base_color: None,
    });
    let mut then = scene(light_at, box_at);
    then.lights[0].intensity = 683.0 * 1.75;
    then.lights[0].color = Vec3::new(1.0, 0.7, 0.4);
    then.objects[1].material.emitted_radiance = Vec3::new(0.2, 0.1, 0.05) * 3.0;
    for (name, choice) in solvers() {
        let mut engine = Engine::new(
            animated.clone(),
            PatchSizing::Count(2000),
            Backend::Auto,
            choice,
        )
        .unwrap();
        engine.converge(2);
        let at_rest = engine.radiosity().to_vec();
        engine.set_time(1.5).unwrap();
        engine.converge(4);
        let mut fresh = Engine::new(
            then.clone(),
            PatchSizing::Count(2000),
            Backend::Auto,
            choice,
        )
        .unwrap();
        fresh.converge(4);
        let a = engine.radiosity();
        let (worst, top) = largest_difference(a, fresh.radiosity());
        let tolerance = if name == "reference" { 1e-5 } else { 0.02 };
        assert!(worst <= tolerance * top, "{name}: {worst} of {top}");
        // And it did change: the light at t = 1.5 is brighter than at rest.
        let sum = |r: &[Vec3]| r.iter().map(|v| v.x as f64).sum::<f64>();
        assert!(
            sum(a) > 1.5 * sum(&at_rest),
            "{name}: {} against {}",
            sum(a),
            sum(&at_rest)
        );
    }
}

/// Pixels in between dark and lit at the far edge of the dark run of `row` (the shadow's
/// edge on the floor): within 8 pixels before and 6 after the last dark pixel, those above a
/// tenth and below nine tenths of the lit floor 6 pixels beyond.
fn edge_width(row: &[f32]) -> usize {
    let top = row.iter().cloned().fold(0.0, f32::max);
    // The floor fills pixels 16..112 of the row (the background beyond is dark too).
    let dark: Vec<usize> = (16..112).filter(|&x| row[x] < 0.02 * top).collect();
    assert!(dark.len() >= 4, "no shadow in the row: {row:?}");
    let end = *dark.last().unwrap();
    let lit = row[end + 6];
    (end.saturating_sub(8)..end + 6)
        .filter(|&x| row[x] > 0.1 * lit && row[x] < 0.9 * lit)
        .count()
}

/// Seen from above, the shadow a box casts on the floor under a point light to its side has
/// an edge a pixel or two wide, where the patches' own light (a patch spans about 6 pixels)
/// gives a ramp: the per-pixel shadow ray is what makes it sharp.
#[test]
fn a_point_lights_shadow_edge_is_sharp_at_pixel_scale() {
    let s = scene(Vec3::new(1.5, 2.0, 0.0), Vec3::new(0.0, 0.25, 0.0));
    let mut e = Engine::new(
        s,
        PatchSizing::Count(400),
        Backend::Auto,
        SolverChoice::preset("reference", "fast").unwrap(),
    )
    .unwrap();
    e.step();
    // Looking down -Y with +Z up: the picture's right is -X, where the shadow falls.
    let camera = Camera::look_at(Vec3::new(0.0, 6.0, 0.0), Vec3::ZERO, 0.8);
    let options = RenderOptions {
        width: 128,
        height: 128,
        spp: 1,
        shading: Shading::Smooth,
    };
    let row = |pixels: &[Vec3]| -> Vec<f32> { (0..128).map(|x| pixels[64 * 128 + x].x).collect() };
    let sharp = edge_width(&row(&e.render(Some(&camera), &options).unwrap().pixels));
    let from_patches =
        shrad::render::render_with_punctual(e.world(), e.radiosity(), &[], &camera, &options);
    let ramp = edge_width(&row(&from_patches.pixels));
    println!("shadow edge: {sharp} pixels per pixel, {ramp} from the patches alone");
    assert!(sharp <= 2, "{sharp} pixels across the shadow's edge");
    assert!(
        ramp >= 4,
        "the patches alone give an edge of {ramp} pixels: the test cannot fail"
    );
}
