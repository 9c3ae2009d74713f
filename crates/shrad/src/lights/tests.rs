//! Punctual lights against closed forms on a plane, and the cache against a fresh one.

use std::f32::consts::PI;

use glam::{Affine3A, Quat, Vec3};
use shrad_scene::{box_mesh, quad, Light, LightKind, Material, Object, Role, Scene};
use shrad_vis::Backend;

use super::{punctual_irradiance_all, PunctualCache};
use crate::direct::mover_spheres::OneMove;
use crate::direct::Moves;
use crate::{PatchSizing, World};

const HALF: f32 = 2.0;

/// A floor of half-width [`HALF`] at y = 0 facing +Y, an optional box (half-size 0.2) resting
/// on it at `box_at`, and `lights`.
fn scene(lights: Vec<Light>, box_at: Option<Vec3>) -> Scene {
    let a = HALF;
    let floor = quad([
        Vec3::new(-a, 0.0, -a),
        Vec3::new(-a, 0.0, a),
        Vec3::new(a, 0.0, a),
        Vec3::new(a, 0.0, -a),
    ]);
    let mut objects = vec![Object {
        role: Some(Role::Boundary),
        ..Object::new("floor", floor, Material::diffuse(Vec3::splat(0.5)))
    }];
    if let Some(at) = box_at {
        objects.push(Object {
            role: Some(Role::Interior),
            world_from_object: Affine3A::from_translation(at),
            ..Object::new(
                "box",
                box_mesh(Vec3::splat(0.2), false),
                Material::diffuse(Vec3::splat(0.5)),
            )
        });
    }
    Scene {
        source: "test".into(),
        objects,
        lights,
        ..Default::default()
    }
}

fn point(at: Vec3, candela: f32) -> Light {
    Light {
        world_from_light: Affine3A::from_translation(at),
        ..Light::new("bulb", LightKind::Point, candela)
    }
}

fn world(s: Scene, patches: usize) -> World {
    World::new(s, PatchSizing::Count(patches), Backend::Auto).unwrap()
}

/// `sum E_i A_i` over the floor's patches.
fn floor_flux(w: &World, e: &[Vec3]) -> f64 {
    w.patches
        .range(0)
        .map(|i| e[i].x as f64 * w.patches.area[i] as f64)
        .sum()
}

#[test]
fn a_point_light_follows_the_inverse_square_and_cosine_law() {
    let (h, cd) = (1.0, 683.0);
    let w = world(scene(vec![point(Vec3::Y * h, cd)], None), 4000);
    let e = punctual_irradiance_all(&w, 16);
    // The flux on the floor is I times the solid angle the square subtends from the light,
    // 4 asin(a^2 / (a^2 + h^2)).
    let (a2, h2) = (HALF * HALF, h * h);
    let expected = (4.0 * (a2 / (a2 + h2)).asin()) as f64;
    let got = floor_flux(&w, &e);
    assert!((got / expected - 1.0).abs() < 2e-3, "{got} vs {expected}");
    // Patch by patch: E = I h / (r^2 + h^2)^(3/2) at the centre (small patches: their
    // footprint average is within a fraction of a percent of it).
    for i in w.patches.range(0) {
        let c = w.patches.centre[i];
        let r2 = c.x * c.x + c.z * c.z;
        let closed = h / (r2 + h2).powf(1.5);
        assert!(
            (e[i].x / closed - 1.0).abs() < 0.01,
            "{c}: {} vs {closed}",
            e[i].x
        );
    }
}

#[test]
fn a_spot_falls_off_smoothly_between_its_cones() {
    let (inner, outer) = (0.3f32, 0.6f32);
    let spot = Light {
        // Shining straight down from 1 above the floor.
        world_from_light: Affine3A::from_rotation_translation(
            Quat::from_rotation_x(-PI / 2.0),
            Vec3::Y,
        ),
        ..Light::new(
            "spot",
            LightKind::Spot {
                inner_cone_angle: inner,
                outer_cone_angle: outer,
            },
            683.0,
        )
    };
    let w = world(scene(vec![spot], None), 6000);
    let e = punctual_irradiance_all(&w, 16);
    // The flux is I times the integral of f over the cone: with f = t^2 and t linear in
    // cos between the cones, 2 pi [(1 - cos inner) + (cos inner - cos outer) / 3].
    let (ci, co) = (inner.cos(), outer.cos());
    let expected = (2.0 * PI * ((1.0 - ci) + (ci - co) / 3.0)) as f64;
    let got = floor_flux(&w, &e);
    assert!((got / expected - 1.0).abs() < 5e-3, "{got} vs {expected}");
    // Inside the inner cone: a point light; outside the outer one: nothing.
    for i in w.patches.range(0) {
        let c = w.patches.centre[i];
        let r = (c.x * c.x + c.z * c.z).sqrt();
        let angle = r.atan();
        let (lo, hi) = (angle - 0.03, angle + 0.03); // the footprint's spread of angles
        if hi < inner {
            let closed = 1.0 / (r * r + 1.0).powf(1.5);
            assert!((e[i].x / closed - 1.0).abs() < 0.01, "{c}");
        } else if lo > outer {
            assert_eq!(e[i].x, 0.0, "{c}");
        }
    }
}

/// A spot Blender wrote falls off as Cycles' `smoothstep((cos a - cos outer) / ((1 - cos
/// outer) b))`, `b = 1 - inner / outer`: half its light where that argument is 1/2, the
/// flux `2 pi I (1 - cos outer) (1 - b / 2)` (the smoothstep's mean over its window is 1/2),
/// and a blend of 0 (equal cones) a hard edge, the flux of the whole cone.
#[test]
fn a_spot_blender_wrote_falls_off_as_blenders_blend() {
    let outer = 0.6f32;
    let down = Affine3A::from_rotation_translation(Quat::from_rotation_x(-PI / 2.0), Vec3::Y);
    for blend in [0.3f32, 0.0] {
        let spot = Light {
            world_from_light: down,
            cone_falloff: shrad_scene::ConeFalloff::Blender,
            ..Light::new(
                "spot",
                LightKind::Spot {
                    inner_cone_angle: outer * (1.0 - blend),
                    outer_cone_angle: outer,
                },
                683.0,
            )
        };
        assert_eq!(spot.problem(), None, "blend {blend}");
        let state = super::LightState::new(&spot, &down).unwrap();
        let co = outer.cos();
        let at_cos = |c: f32| {
            let a = c.clamp(-1.0, 1.0).acos();
            state.cone(Vec3::new(a.sin(), -a.cos(), 0.0))
        };
        let w = (1.0 - co) * blend;
        assert_eq!(at_cos(co - 1e-3), 0.0);
        assert!((at_cos(1.0) - 1.0).abs() < 1e-6);
        if blend > 0.0 {
            assert!(
                (at_cos(co + 0.5 * w) - 0.5).abs() < 1e-3,
                "{}",
                at_cos(co + 0.5 * w)
            );
            let x = 0.25f32;
            let smooth = x * x * (3.0 - 2.0 * x);
            assert!((at_cos(co + x * w) - smooth).abs() < 1e-3);
        } else {
            assert!((at_cos(co + 1e-4) - 1.0).abs() < 1e-6, "a hard edge");
        }
        let expected = 2.0 * std::f64::consts::PI * (1.0 - co as f64) * (1.0 - blend as f64 / 2.0);
        let flux = state.emitted_flux();
        assert!(
            (flux / expected - 1.0).abs() < 1e-3,
            "blend {blend}: {flux} vs {expected}"
        );
    }
}

/// A rug 1 mm above the floor of a 10 m room shadows the floor under it: with rays offset by
/// 1e-4 of the scene's diagonal (1.4 mm here) the floor's shadow rays began above the rug
/// and the floor under it took the lamp's full light (Mitsuba: 0.1 % of it).
#[test]
fn a_rug_a_millimetre_above_the_floor_shadows_it() {
    let a = 5.0;
    let floor = quad([
        Vec3::new(-a, 0.0, -a),
        Vec3::new(-a, 0.0, a),
        Vec3::new(a, 0.0, a),
        Vec3::new(a, 0.0, -a),
    ]);
    let r = 0.5;
    let rug = quad([
        Vec3::new(-r, 0.001, -r),
        Vec3::new(-r, 0.001, r),
        Vec3::new(r, 0.001, r),
        Vec3::new(r, 0.001, -r),
    ]);
    let s = Scene {
        source: "rug".into(),
        objects: vec![
            Object {
                role: Some(Role::Boundary),
                ..Object::new("floor", floor, Material::diffuse(Vec3::splat(0.5)))
            },
            Object {
                role: Some(Role::Boundary),
                ..Object::new("rug", rug, Material::diffuse(Vec3::splat(0.5)))
            },
        ],
        lights: vec![point(Vec3::new(0.3, 3.0, 0.2), 683.0)],
        ..Default::default()
    };
    let w = world(s, 20000);
    let e = punctual_irradiance_all(&w, 16);
    let (mut under, mut open) = (0, 0);
    for i in w.patches.range(0) {
        let c = w.patches.centre[i];
        let reach = w.patches.radius(i);
        if c.x.abs() + reach < r && c.z.abs() + reach < r {
            under += 1;
            assert_eq!(e[i].x, 0.0, "floor patch at {c} under the rug is lit");
        } else if c.x.abs() - reach > r || c.z.abs() - reach > r {
            open += (e[i].x > 0.0) as usize;
        }
    }
    assert!(
        under > 20 && open > 1000,
        "{under} patches under the rug, {open} lit beside it"
    );
}

#[test]
fn a_sun_gives_e_cos_theta_everywhere() {
    let theta = 0.7f32;
    let towards = Vec3::new(theta.sin(), -theta.cos(), 0.0);
    let sun = Light {
        world_from_light: Affine3A::from_quat(Quat::from_rotation_arc(-Vec3::Z, towards)),
        ..Light::new("sun", LightKind::Directional, 683.0 * 3.0)
    };
    let w = world(scene(vec![sun], None), 500);
    let e = punctual_irradiance_all(&w, 4);
    for i in w.patches.range(0) {
        assert!((e[i].x - 3.0 * theta.cos()).abs() < 1e-5, "{}", e[i].x);
    }
}

#[test]
fn the_cache_after_moves_and_light_changes_equals_a_fresh_one() {
    let lights = vec![
        point(Vec3::new(0.3, 1.5, 0.2), 683.0),
        Light {
            world_from_light: Affine3A::from_quat(Quat::from_rotation_arc(
                -Vec3::Z,
                Vec3::new(0.4, -1.0, 0.3).normalize(),
            )),
            ..Light::new("sun", LightKind::Directional, 683.0)
        },
    ];
    let mut w = world(scene(lights, Some(Vec3::new(0.0, 0.2, 0.0))), 3000);
    let all: Vec<u32> = (0..w.patches.len() as u32).collect();
    let mut cache = PunctualCache::new(&w, all.clone(), 16);
    let mut backwards = PunctualCache::new(&w, all.iter().rev().copied().collect(), 16);
    let box_world = |w: &World| {
        w.patches.shapes[1]
            .bounds()
            .unwrap()
            .transformed(w.patches.world_from_local[1])
    };
    let fresh_rays = {
        let before = w.rays_cast();
        let _ = PunctualCache::new(&w, all.clone(), 16);
        w.rays_cast() - before
    };
    for step in 0..4 {
        let old = box_world(&w);
        let at = Vec3::new(0.5 * step as f32 - 0.6, 0.2, 0.1 * step as f32);
        w.move_object(1, Affine3A::from_translation(at)).unwrap();
        let new = box_world(&w);
        let before = w.rays_cast();
        cache.update(&w, Moves::boxes(&[old], &[new]), (&[1], 16), |_| true);
        let traced = w.rays_cast() - before;
        assert!(
            traced < fresh_rays / 2,
            "{traced} of {fresh_rays} re-traced"
        );
        let fresh = PunctualCache::new(&w, all.clone(), 16);
        assert_eq!(cache.irradiance(), fresh.irradiance(), "after move {step}");
        // Receivers in any order: the mover's are found by a pass, not by their ranges.
        backwards.update(&w, Moves::boxes(&[old], &[new]), (&[1], 16), |_| true);
        let mut turned = backwards.irradiance().to_vec();
        turned.reverse();
        assert_eq!(turned, fresh.irradiance(), "backwards, after move {step}");
    }
    // A brighter light: nothing traced. A moved light: its own term again.
    let m = w.scene.lights[0].world_from_light;
    assert!(w.set_light(0, m, Vec3::new(1.0, 0.5, 0.2), 2000.0).unwrap());
    let before = w.rays_cast();
    cache.update(&w, Moves::boxes(&[], &[]), (&[], 16), |_| true);
    assert_eq!(w.rays_cast(), before, "a strength change traces nothing");
    assert_eq!(
        cache.irradiance(),
        PunctualCache::new(&w, all.clone(), 16).irradiance()
    );
    let moved = Affine3A::from_translation(Vec3::new(-0.7, 1.1, 0.4));
    assert!(w.set_light(0, moved, Vec3::ONE, 683.0).unwrap());
    cache.update(&w, Moves::boxes(&[], &[]), (&[], 16), |_| true);
    assert_eq!(
        cache.irradiance(),
        PunctualCache::new(&w, all.clone(), 16).irradiance()
    );
    // Bad values are errors, and change nothing.
    assert!(w.set_light(0, moved, Vec3::ONE, -1.0).is_err());
    assert!(w.set_light(5, moved, Vec3::ONE, 1.0).is_err());
}

#[test]
fn a_box_casts_a_shadow_and_its_lit_side_is_lit() {
    let w = world(
        scene(
            vec![point(Vec3::new(0.0, 2.0, 0.0), 683.0)],
            Some(Vec3::new(0.0, 0.2, 0.0)),
        ),
        3000,
    );
    let e = punctual_irradiance_all(&w, 16);
    // Floor patches right under the box are in its shadow; the box's top is lit.
    let p = &w.patches;
    for i in p.range(0) {
        let c = p.centre[i];
        if c.x.abs() < 0.15 && c.z.abs() < 0.15 {
            assert_eq!(e[i], Vec3::ZERO, "{c}");
        }
    }
    let mut tops = 0;
    for i in p.range(1).filter(|&i| p.normal[i].y > 0.9) {
        let (c, h) = (p.centre[i], 2.0 - p.centre[i].y);
        let closed = h / (c.x * c.x + c.z * c.z + h * h).powf(1.5);
        assert!(
            (e[i].x / closed - 1.0).abs() < 0.01,
            "{c}: {} vs {closed}",
            e[i].x
        );
        tops += 1;
    }
    assert!(tops > 0);
}

/// The sky's part of the cache (`crate::sky`) after an occluder moved equals a fresh cache,
/// tracing only the rays the box's path meets; a changed sky re-traces it.
/// A moving ball's shadow rays to a point light and to the sky are found by its boxes and by
/// a sphere about it where it was and where it is (`direct/mover_spheres.rs`): far fewer
/// rays are re-traced than by its boxes alone, and every receiver but the ball's own (which
/// wait, unread, while it moves) has the light of a fresh cache. Fails if the spheres are
/// not used (as many rays), or if they drop a ray the move changed.
#[test]
fn a_moving_balls_rays_to_a_lamp_and_the_sky_are_found_by_its_spheres_and_stay_exact() {
    let mut s = shrad_scene::room(&shrad_scene::RoomParams {
        objects: 8,
        patches: 6000,
        big_object_patches: None,
    });
    let b = s.bounds().unwrap();
    s.lights
        .push(point(b.centre() + 0.4 * b.size().y * Vec3::Y, 2000.0));
    s.environment = Some(shrad_scene::Environment::uniform(Vec3::new(0.3, 0.4, 0.6)));
    let mut w = world(s, 6000);
    let ball = (w.scene.objects.iter())
        .position(|o| o.name == "sphere_2")
        .unwrap();
    let all: Vec<u32> = (0..w.patches.len() as u32).collect();
    let mut cache = PunctualCache::new(&w, all.clone(), 16);
    let mut boxes_only = cache.clone();
    let slide = OneMove::slide(&mut w, ball, Vec3::X * 0.05 * b.size().x);
    let rays = |cache: &mut PunctualCache, moves: Moves| {
        let before = w.rays_cast();
        cache.update(&w, moves, (&[ball], 16), |_| false);
        w.rays_cast() - before
    };
    let by_spheres = rays(&mut cache, slide.with_spheres());
    let by_boxes = rays(&mut boxes_only, slide.boxes_only());
    assert!(
        by_spheres * 5 < by_boxes * 4,
        "{by_spheres} rays re-traced with the spheres, {by_boxes} by the boxes alone"
    );
    let fresh = PunctualCache::new(&w, all, 16);
    let own = w.patches.range(ball);
    let off = |c: &PunctualCache| {
        (c.irradiance().iter().zip(fresh.irradiance()).enumerate())
            .filter(|(i, (a, b))| !own.contains(i) && a != b)
            .count()
    };
    assert_eq!(off(&cache), 0, "receivers off the fresh cache (spheres)");
    assert_eq!(off(&boxes_only), 0, "receivers off the fresh cache (boxes)");
}

#[test]
fn the_sky_after_moves_and_a_sky_change_equals_a_fresh_one() {
    let texels = (0..16 * 8)
        .map(|k| Vec3::new(0.2 + (k % 7) as f32, 0.5, 0.1 * (k / 16) as f32))
        .collect();
    let map = shrad_scene::EnvMap::new("t.exr".into(), 16, 8, texels).unwrap();
    let mut s = scene(Vec::new(), Some(Vec3::new(0.0, 0.2, 0.0)));
    s.environment = Some(shrad_scene::Environment::from_map(map));
    let mut w = world(s, 2000);
    let all: Vec<u32> = (0..w.patches.len() as u32).collect();
    let mut cache = PunctualCache::new(&w, all.clone(), 16);
    let box_world = |w: &World| {
        w.patches.shapes[1]
            .bounds()
            .unwrap()
            .transformed(w.patches.world_from_local[1])
    };
    let before = w.rays_cast();
    let _ = PunctualCache::new(&w, all.clone(), 16);
    let fresh_rays = w.rays_cast() - before;
    for step in 0..3 {
        let old = box_world(&w);
        let at = Vec3::new(0.4 * step as f32 - 0.5, 0.2, -0.1 * step as f32);
        w.move_object(1, Affine3A::from_translation(at)).unwrap();
        let new = box_world(&w);
        let before = w.rays_cast();
        let changed = cache.update(&w, Moves::boxes(&[old], &[new]), (&[1], 16), |_| true);
        assert!(!changed.is_empty());
        let traced = w.rays_cast() - before;
        assert!(traced < fresh_rays, "{traced} of {fresh_rays} re-traced");
        let fresh = PunctualCache::new(&w, all.clone(), 16);
        assert_eq!(cache.irradiance(), fresh.irradiance(), "after move {step}");
    }
    let uniform = shrad_scene::Environment::uniform(Vec3::new(0.3, 0.2, 0.1));
    assert!(w.set_sky(Some(uniform)).unwrap());
    assert!(!cache.same_sky(&w));
    cache.update(&w, Moves::boxes(&[], &[]), (&[], 16), |_| true);
    assert_eq!(
        cache.irradiance(),
        PunctualCache::new(&w, all.clone(), 16).irradiance()
    );
    assert!(w.set_sky(None).unwrap());
    cache.update(&w, Moves::boxes(&[], &[]), (&[], 16), |_| true);
    assert!(cache.irradiance().iter().all(|e| *e == Vec3::ZERO));
}

/// A receiver that moved is traced when its light is read after the update; unread, it keeps
/// what it had and casts no ray, and the first update where it rests traces it: the cache
/// then equals a fresh one. The receivers it shadows are exact at every update either way.
/// A point light and a sky (whose part follows the lights' choice). Fails if an unread mover
/// is traced anyway, if a waiting one is never traced again, or if the blocks skip a
/// receiver whose rays a move changed.
#[test]
fn a_moving_receiver_is_traced_only_when_read_coarse_while_it_moves_and_whole_at_rest() {
    let lights = vec![point(Vec3::new(0.3, 1.5, 0.2), 683.0)];
    let mut w = world(scene(lights, Some(Vec3::new(0.0, 0.2, 0.0))), 3000);
    let sky = shrad_scene::Environment::uniform(Vec3::new(0.3, 0.2, 0.1));
    assert!(w.set_sky(Some(sky)).unwrap());
    let all: Vec<u32> = (0..w.patches.len() as u32).collect();
    let mut cache = PunctualCache::new(&w, all.clone(), 16);
    let mut read = cache.clone();
    // Read while it moves, with a quarter of the samples (`coarse_while_moving`).
    let mut coarse = cache.clone();
    let box_world = |w: &World| {
        w.patches.shapes[1]
            .bounds()
            .unwrap()
            .transformed(w.patches.world_from_local[1])
    };
    let object = w.patches.object.clone();
    let on_box = |i: u32| object[i as usize] == 1;
    let box_ks: Vec<usize> = (0..all.len()).filter(|&k| on_box(all[k])).collect();
    for step in 0..3 {
        let held: Vec<Vec3> = box_ks.iter().map(|&k| cache.irradiance()[k]).collect();
        let old = box_world(&w);
        let at = Vec3::new(0.4 * step as f32 - 0.5, 0.2, -0.1 * step as f32);
        w.move_object(1, Affine3A::from_translation(at)).unwrap();
        let new = box_world(&w);
        let before = w.rays_cast();
        cache.update(&w, Moves::boxes(&[old], &[new]), (&[1], 16), |_| false);
        let unread_rays = w.rays_cast() - before;
        let before = w.rays_cast();
        read.update(&w, Moves::boxes(&[old], &[new]), (&[1], 16), |_| true);
        let read_rays = w.rays_cast() - before;
        let before = w.rays_cast();
        coarse.update(&w, Moves::boxes(&[old], &[new]), (&[1], 4), |_| true);
        let coarse_rays = w.rays_cast() - before;
        assert!(cache.catching_up() && !read.catching_up() && coarse.catching_up());
        assert!(
            unread_rays + box_ks.len() as u64 <= read_rays,
            "move {step}: {unread_rays} rays unread, {read_rays} read"
        );
        // The box's own rays: all of them read, a quarter coarse (both of the light and the
        // sky), the rays near it the same.
        let (own, own_coarse) = (read_rays - unread_rays, coarse_rays - unread_rays);
        assert!(
            own_coarse * 4 <= own + 8 && own_coarse * 4 + 8 >= own,
            "move {step}: the box's own rays {own} whole, {own_coarse} coarse"
        );
        let now: Vec<Vec3> = box_ks.iter().map(|&k| cache.irradiance()[k]).collect();
        assert_eq!(now, held, "move {step}: an unread mover's light changed");
        let fresh = PunctualCache::new(&w, all.clone(), 16);
        assert_eq!(read.irradiance(), fresh.irradiance(), "move {step}, read");
        let others = |c: &PunctualCache| -> Vec<Vec3> {
            (0..all.len())
                .filter(|k| box_ks.binary_search(k).is_err())
                .map(|k| c.irradiance()[k])
                .collect()
        };
        assert_eq!(
            others(&cache),
            others(&fresh),
            "move {step}: the shadows it casts"
        );
        assert_eq!(others(&coarse), others(&fresh), "move {step}: coarse");
        // The box's light from 4 samples a patch: its total near the whole trace's.
        let total = |c: &PunctualCache| -> f32 {
            box_ks
                .iter()
                .map(|&k| c.irradiance()[k].element_sum())
                .sum()
        };
        let (t_coarse, t_fresh) = (total(&coarse), total(&fresh));
        assert!(
            (t_coarse - t_fresh).abs() <= 0.05 * t_fresh && t_coarse != t_fresh,
            "move {step}: the box's light coarse {t_coarse}, whole {t_fresh}"
        );
    }
    // At rest: the waiting receivers, and those traced coarse, are traced whole.
    let fresh = PunctualCache::new(&w, all.clone(), 16);
    for c in [&mut cache, &mut coarse] {
        c.update(&w, Moves::boxes(&[], &[]), (&[], 16), |_| false);
        assert!(!c.catching_up());
        assert_eq!(c.irradiance(), fresh.irradiance());
    }
}
