//! The moving window: after a solver's still frames, one object moves before every frame
//! (the paper's case) and those frames are timed, then the last of them is measured against
//! a reference solve of the moved state (the error while moving, issue 24) and its rays
//! against the scene's ray floor ([`crate::rays`]).
//!
//! The sweep: back and forth along x by [`MOVE_REACH`] of the scene's extent, one period in
//! [`MOVE_PERIOD_FRAMES`] frames ([`moved_transform`]); a window runs on to the sweep's next
//! turning point ([`moving_frames`]), so its last frame leaves the object at its farthest
//! from rest.

use std::time::Instant;

use glam::{Affine3A, Vec3};
use shrad::engine::Engine;
use shrad::frame::FrameStats;
use shrad::metrics::relative_error;
use shrad::reference::{solve, ReferenceOptions};
use shrad::{NoProgress, World};

use crate::rays::RayRate;
use crate::report::Moving;
use crate::run::{check_radiosity, median, step_medians};
use crate::scenes::Table;

/// How far the moving object goes either side of where it rests, as a fraction of the
/// scene's extent along x (0.4 m in the 8 m room).
pub const MOVE_REACH: f32 = 0.05;
/// Frames of one back-and-forth of the moving object.
pub const MOVE_PERIOD_FRAMES: usize = 16;

/// The moving frames actually run for `frames` asked: the next count that ends at a turning
/// point of the sweep (a quarter or three quarters of a period), so that the last frame,
/// whose error is measured, leaves the object at its farthest from rest (a whole number of
/// periods would bring it back exactly to rest).
pub fn moving_frames(frames: usize) -> usize {
    let quarter = MOVE_PERIOD_FRAMES / 4;
    let half = MOVE_PERIOD_FRAMES / 2;
    if frames == 0 {
        return 0;
    }
    frames + (quarter + half - frames % half) % half
}

/// Where the moving object is at moving frame `k` (1-based): `rest` moved along x by
/// `reach` times the sweep's phase. The phase is taken from `k` modulo the period, so that
/// equal phases give bit-identical transforms (the moved reference is shared between the
/// solvers that end there).
pub fn moved_transform(rest: Affine3A, reach: f32, k: usize) -> Affine3A {
    let k = k % MOVE_PERIOD_FRAMES;
    let phase = (k as f32 * std::f32::consts::TAU / MOVE_PERIOD_FRAMES as f32).sin();
    Affine3A::from_translation(Vec3::X * reach * phase) * rest
}

/// The object moved in the moving window: Table 3's grown object (the first interior one);
/// on the objects scenes the smallest box (the smallest interior object when there is no
/// box); else the largest interior object.
pub(crate) fn mover(world: &World, table: Table, interior: &[usize]) -> Option<usize> {
    let p = &world.patches;
    match table {
        Table::BigObject => interior.first().copied(),
        Table::Scaling => interior.iter().copied().max_by_key(|&o| p.range(o).len()),
        Table::Objects => {
            let is_box = |o: usize| world.scene.objects[o].name.starts_with("box_");
            let smallest = |f: &dyn Fn(usize) -> bool| {
                interior
                    .iter()
                    .copied()
                    .filter(|&o| f(o))
                    .min_by_key(|&o| p.range(o).len())
            };
            smallest(&is_box).or_else(|| smallest(&|_| true))
        }
    }
}

/// A reference solve of a moved state: the world with `object` at `world_from_local`.
pub(crate) struct MovedReference {
    pub(crate) object: usize,
    pub(crate) world_from_local: Affine3A,
    pub(crate) radiosity: Vec<Vec3>,
}

/// The reference solves of one scene's moved states: the last one is kept for the next
/// solver whose window ends at the same place (a moved state is identified by the mover's
/// exact local transform; every other object is at rest).
#[derive(Default)]
pub(crate) struct MovedReferences {
    /// The last moved state solved.
    pub(crate) last: Option<MovedReference>,
    /// Moved states solved so far.
    pub(crate) solves: usize,
    /// Their summed time (s).
    pub(crate) seconds: f64,
}

impl MovedReferences {
    /// The reference solve of `world` as it is, with object `o` moved: solved once for each
    /// moved state, checked like the scene's reference.
    pub(crate) fn of(
        &mut self,
        world: &World,
        o: usize,
        options: &ReferenceOptions,
    ) -> Result<&[Vec3], String> {
        let xf = world.patches.world_from_local[o];
        let known = self
            .last
            .as_ref()
            .is_some_and(|m| m.object == o && m.world_from_local == xf);
        if !known {
            let t = Instant::now();
            let (radiosity, _) = solve(world, options, &NoProgress);
            self.seconds += t.elapsed().as_secs_f64();
            self.solves += 1;
            check_radiosity(world, &radiosity).map_err(|e| format!("the moved reference: {e}"))?;
            self.last = Some(MovedReference {
                object: o,
                world_from_local: xf,
                radiosity,
            });
        }
        Ok(self.last.as_ref().map_or(&[], |m| m.radiosity.as_slice()))
    }
}

/// Step `frames` frames, moving object `o` before each ([`moved_transform`]). The radiosity
/// is checked after the last frame; the object is left where the last frame put it.
pub(crate) fn time_moving(
    engine: &mut Engine,
    o: usize,
    frames: usize,
) -> Result<Vec<FrameStats>, String> {
    let rest = engine.transform(o);
    let size = engine
        .world()
        .scene
        .bounds()
        .ok_or_else(|| "the scene is empty".to_string())?
        .size();
    let reach = MOVE_REACH * size.x;
    let mut stats = Vec::with_capacity(frames);
    for k in 1..=frames {
        engine
            .set_transform(o, moved_transform(rest, reach, k))
            .map_err(|e| e.to_string())?;
        stats.push(engine.step());
    }
    check_radiosity(engine.world(), engine.radiosity())?;
    Ok(stats)
}

/// The whole window: [`time_moving`] over `frames` frames, then the last frame's error
/// against the reference of that moved state (before the object is put back) and the
/// frames' rays against the floor at `rate`. The object is left moved.
pub(crate) fn moving_window(
    engine: &mut Engine,
    o: usize,
    frames: usize,
    references: &mut MovedReferences,
    options: &ReferenceOptions,
    rate: &RayRate,
) -> Result<Moving, String> {
    let stats = time_moving(engine, o, frames).map_err(|e| format!("with a moving object: {e}"))?;
    let world = engine.world();
    let reference = references.of(world, o, options)?;
    let frame_ms_median = median(&stats.iter().map(|s| s.frame_ms).collect::<Vec<_>>());
    let rays_median = median(&stats.iter().map(|s| s.rays_cast as f64).collect::<Vec<_>>());
    let ray_floor_ms = rate.floor_ms(rays_median);
    Ok(Moving {
        object: world.scene.objects[o].name.clone(),
        object_patches: world.patches.range(o).len(),
        frame_ms_median,
        frame_ms_max: stats.iter().map(|s| s.frame_ms).fold(0.0, f64::max),
        step_ms: step_medians(&stats),
        frames: stats.len(),
        error: relative_error(&world.patches, engine.radiosity(), reference),
        rays_median,
        ray_floor_ms,
        over_ray_floor: if ray_floor_ms > 0.0 {
            frame_ms_median / ray_floor_ms
        } else {
            f64::NAN
        },
        ..Moving::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenes::{build_world, SceneSpec};
    use crate::solvers::SolverKind;
    use crate::BenchOptions;
    use shrad::scene::Role;
    use shrad::vis::Backend;

    fn interior(world: &World) -> Vec<usize> {
        let p = &world.patches;
        (0..p.object_role.len())
            .filter(|&o| p.object_role[o] == Role::Interior)
            .collect()
    }

    #[test]
    fn the_moving_window_ends_at_a_turning_point() {
        for (asked, run) in [
            (0, 0),
            (3, 4),
            (4, 4),
            (6, 12),
            (12, 12),
            (16, 20),
            (36, 36),
        ] {
            assert_eq!(moving_frames(asked), run, "{asked}");
        }
        let rest = Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0));
        for asked in [1, 3, 8, 16, 36, 128] {
            let k = moving_frames(asked);
            assert!(k >= asked);
            let dx = moved_transform(rest, 0.4, k).translation.x - 1.0;
            assert!((dx.abs() - 0.4).abs() < 1e-5, "{asked}: {dx}");
        }
        // The phase is taken modulo the period: equal phases, equal bits.
        assert_eq!(
            moved_transform(rest, 0.4, 4),
            moved_transform(rest, 0.4, 20)
        );
    }

    /// The error while moving is taken against a reference of the moved state: it is what
    /// `Engine::error` says before the object goes back, and not the error against the
    /// still scene's reference.
    #[test]
    fn the_error_while_moving_is_of_the_moved_state() {
        let spec = SceneSpec::tiny(Table::Scaling, 2, 1200);
        let world = build_world(&spec, Backend::Auto).unwrap();
        let reference_options = ReferenceOptions::fast();
        let (reference, _) = solve(&world, &reference_options, &NoProgress);
        let o = mover(&world, Table::Scaling, &interior(&world)).unwrap();
        let mut engine = Engine::from_world(world, SolverKind::Dispersive.choice()).unwrap();
        engine.converge(2);
        let mut references = MovedReferences::default();
        let m = moving_window(
            &mut engine,
            o,
            moving_frames(4),
            &mut references,
            &reference_options,
            &RayRate::default(),
        )
        .unwrap();
        let p = &engine.world().patches;
        let against_rest = relative_error(p, engine.radiosity(), &reference);
        engine.set_reference_options(reference_options);
        let said = engine.error();
        assert!(
            (said.overall - m.error.overall).abs() <= 1e-9,
            "{said:?} {:?}",
            m.error
        );
        assert!(
            (m.error.overall - against_rest.overall).abs() > 1e-4,
            "{:?} {against_rest:?}",
            m.error
        );
        // Without a measured rate there is no floor.
        assert!(m.ray_floor_ms.is_nan() && m.over_ray_floor.is_nan());
        // Asked again for the same state, the solve is not repeated.
        references
            .of(engine.world(), o, &reference_options)
            .unwrap();
        assert_eq!(references.solves, 1);
    }

    /// On the objects scenes the smallest box moves.
    #[test]
    fn the_objects_scenes_move_their_smallest_box() {
        let spec = SceneSpec::tiny(Table::Objects, 8, 3000);
        let world = build_world(&spec, Backend::Auto).unwrap();
        let p = &world.patches;
        let interior = interior(&world);
        assert_eq!(interior.len(), 8);
        let o = mover(&world, Table::Objects, &interior).unwrap();
        assert!(world.scene.objects[o].name.starts_with("box_"));
        let boxes = interior
            .iter()
            .filter(|&&b| world.scene.objects[b].name.starts_with("box_"));
        assert!(boxes.clone().count() >= 2);
        for &b in boxes {
            assert!(p.range(o).len() <= p.range(b).len());
        }
        // Only the dispersive default runs there.
        let options = BenchOptions::new(true);
        assert_eq!(options.solvers_for(&spec), vec![SolverKind::Dispersive]);
    }
}
