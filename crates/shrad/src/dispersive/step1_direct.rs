//! Step 1 of the frame (paper 2.3.2, "计算光源对边界的直接光照"): direct light from the
//! lights on the boundary, and on interior patches when `direct_on_interior` (the paper
//! leaves those to the probes). With it, the frame's bookkeeping of what changed: which
//! objects a mover disturbed (for the scheduler) and the boxes the movers swept.
//!
//! The paper recomputes direct light every frame. Here it is cached with its shadow rays
//! ([`DirectCache`]) and only the shadow rays a mover may have changed are re-traced: a
//! blocked ray whose segment meets a mover's old box, a free one whose segment meets its new
//! box (receivers whose cone to a light misses every box are skipped at once). The result is
//! what a full recomputation with the same samples gives, except while an object moves under
//! `coarse_while_moving`: its own patches with fewer samples, a quarter of them traced a
//! frame, and a quarter of the other receivers' shadow rays found a frame ([`MOVING_STRIDE`]);
//! all exact again at the first frame after it rests. The light surfaces' part is
//! recomputed when one of them moved or changed; a punctual light that moved re-traces only
//! its own term, one whose colour or intensity changed is rescaled (`lights/cache.rs`).

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::{Aabb, Role};

use super::object_state::ObjectProbes;
use super::setup::world_box;
use super::{Changes, Dispersive, DispersiveOptions};
use crate::direct::mover_spheres::SweptBox;
use crate::direct::{DirectCache, Moves, Sphere};
use crate::lights::PunctualCache;
use crate::World;

/// Where every object is: its world box and a sphere about it (`None` for a shape without
/// vertices), aligned with the scene's objects.
pub(super) type ObjectPlaces<'a> = (&'a [Aabb], &'a [Option<Sphere>]);

/// While an object moves with `coarse_while_moving`, Step 1 traces one in this many of its
/// own patches each frame (in turn); the others keep their last visible fraction under their
/// exact unoccluded light where they are when Step 2 reads it, the frames that light the
/// object (its light lags at most 3 frames behind it).
/// When a mover changes more shadow rays than `SHADOW_RAYS_AT_ONCE` (`direct/cache.rs`; the 1M
/// room's largest object, not the 77k or 129k room's), one in this many of the other
/// receivers has them found in turn too, against every move since its last turn: finding
/// and re-tracing them took 38 ms a frame there (under load), 12 ms in turns, and its shadow
/// lags as its light does. Every patch is exact again, with every sample, when it rests.
const MOVING_STRIDE: usize = 4;

/// The disturbance of an object near one that has just stopped: above the stopped one's own
/// (4), so the scheduler updates the neighbours first (`note_changes`).
const NEIGHBOUR_OF_STOPPED: f32 = 8.0;

impl Dispersive {
    /// Mark objects near what moved (or every object, when a light changed) as disturbed.
    /// A surface whose emission or reflectance changed (`relit`) changed the light every
    /// object sees, whatever its role: a box painted white under a lamp must wake.
    pub(super) fn note_changes(&mut self, world: &World, changes: &Changes) {
        let p = &world.patches;
        let lights_changed = !changes.lights.is_empty()
            || !changes.relit.is_empty()
            || (changes.moved.iter()).any(|&o| p.object_role[o] == Role::Light);
        let boxes: Vec<(Vec3, f32)> = changes
            .moved
            .iter()
            .filter_map(|&o| {
                let r = p.range(o);
                let pts = r.map(|i| p.centre[i]);
                let (lo, hi) = pts.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), c| {
                    (a.min(c), b.max(c))
                });
                lo.is_finite()
                    .then(|| (0.5 * (lo + hi), 0.5 * (hi - lo).length()))
            })
            .collect();
        // Each object's probe box as a sphere (world centre, radius), and whether it is a
        // neighbour of one of `others`: within three times the two radii.
        let sphere = |ob: &ObjectProbes| {
            let m = p.world_from_local[ob.object];
            let c = m.transform_point3(ob.centre_local());
            (c, 0.5 * m.transform_vector3(ob.probe_box.size()).length())
        };
        let near = |(c, r): (Vec3, f32), others: &[(Vec3, f32)]| {
            (others.iter()).any(|(oc, or)| (c - *oc).length() < 3.0 * (r + or))
        };
        // The objects that moved last frame and rest now.
        let stopped: Vec<(Vec3, f32)> = (self.objects.iter())
            .filter(|ob| ob.moving && !changes.moved.contains(&ob.object))
            .map(sphere)
            .collect();
        for (k, ob) in self.objects.iter_mut().enumerate() {
            let was_moving = ob.moving;
            ob.moving = changes.moved.contains(&ob.object);
            if !ob.moving && ob.coarse_light {
                // It stopped with light from a coarse update: full resolution soon, with its
                // contact openness measured where it rests (once: a near field measured
                // over several frames under a budget goes on where it stopped).
                self.scheduler.disturb(k, 4.0);
                if was_moving {
                    ob.forget_openness();
                }
            }
            // Its surroundings changed: when it starts to move and when it stops, its probes
            // go back to the corners and are checked again. While it goes on moving, a probe
            // moved inward stays where its last update found it valid and is checked there
            // (moved further in if it is not): a ball rolled along the floor sank its four
            // lower probes into the floor at every update, and each was captured twice (the
            // 77k room's frames that light it 6.8 -> 6.1 ms, the same light).
            if ob.moving != was_moving {
                ob.probe_scale = [Vec3::ONE; 8];
            }
            if ob.moving {
                self.scheduler.disturb(k, 4.0);
                ob.probe_vis.forget();
                // Contact openness is measured again at every update, except while coarse
                // updates stand in for it (`coarse_while_moving`): then the last measure
                // serves until it rests (above).
                ob.near_pending = None;
                if !self.options.coarse_while_moving {
                    ob.forget_openness();
                }
                continue;
            }
            if lights_changed {
                self.scheduler.disturb(k, 2.0);
            }
            let at = sphere(ob);
            if near(at, &boxes) {
                self.scheduler.disturb(k, 2.0);
            }
            // The neighbours of an object that has just stopped are updated before it: their
            // light, and what they send the walls, still carry its path, and its own full
            // update first raised the error by 0.27 points before they caught up (issue 22
            // item 3; with them first the error falls frame by frame, docs/results.md §14).
            if !was_moving && near(at, &stopped) {
                self.scheduler.disturb(k, NEIGHBOUR_OF_STOPPED);
            }
        }
    }

    /// Boxes swept by the objects that moved since the last frame: for each, in order, its
    /// old box then its new one, each with a sphere about the object there
    /// ([`crate::Patches::world_sphere`]). Updates the remembered boxes and spheres.
    pub(super) fn swept_boxes(&mut self, world: &World, changes: &Changes) -> Vec<SweptBox> {
        let mut swept = Vec::new();
        for &o in &changes.moved {
            let old = (self.object_boxes[o], self.object_spheres[o]);
            let new = (world_box(world, o), world.patches.world_sphere(o));
            swept.push(old);
            swept.push(new);
            (self.object_boxes[o], self.object_spheres[o]) = new;
            if !self.direct_sync.moved.contains(&o) {
                self.direct_sync.moved.push(o);
            }
        }
        swept
    }

    /// Step 1's state taken out of the solver ([`Step1::direct_to_boundary`] runs on it
    /// beside Step 2's first object); [`Dispersive::put_step1`] puts it back.
    pub(super) fn take_step1(&mut self) -> Step1 {
        Step1 {
            direct_valid: self.direct_valid,
            direct_cache: std::mem::take(&mut self.direct_cache),
            punctual: std::mem::take(&mut self.punctual),
            direct_sync: std::mem::take(&mut self.direct_sync),
            direct: std::mem::take(&mut self.direct),
            touched: std::mem::take(&mut self.touched),
        }
    }

    /// Put back what [`Dispersive::take_step1`] took.
    pub(super) fn put_step1(&mut self, s: Step1) {
        self.direct_valid = s.direct_valid;
        self.direct_cache = s.direct_cache;
        self.punctual = s.punctual;
        self.direct_sync = s.direct_sync;
        self.direct = s.direct;
        self.touched = s.touched;
    }

    /// Whether a budget's deadline may carry Step 1 over to the next frame: never two
    /// frames running, never when a light or an emitting surface changed (every later step
    /// reads that light), never before it first ran.
    pub(super) fn may_carry_direct(&self, world: &World, changes: &Changes) -> bool {
        self.direct_valid
            && !self.direct_sync.carried
            && !changes.light_changed()
            && changes.relit.is_empty()
            && !self.direct_sync.moved.iter().any(|&o| emits(world, o))
    }

    /// The punctual lights' direct irradiance of every patch (empty without punctual lights).
    pub fn punctual_irradiance(&self) -> &[Vec3] {
        &self.punctual.by_patch
    }
}

/// Whether object `o` is a light or emits (Step 1 then recomputes the light surfaces' part).
fn emits(world: &World, o: usize) -> bool {
    let p = &world.patches;
    p.object_role[o] == Role::Light || world.exitance[p.range(o).start].max_element() > 0.0
}

/// Step 1's part of the solver's state: what [`Step1::direct_to_boundary`] reads and writes
/// besides the options and the objects' boxes, so that it can run beside Step 2's first
/// object (which reads none of it until it stores its light).
#[derive(Debug, Default)]
pub(super) struct Step1 {
    direct_valid: bool,
    direct_cache: DirectCache,
    punctual: PunctualDirect,
    pub(super) direct_sync: DirectSync,
    direct: Vec<Vec3>,
    touched: super::touched::Touched,
}

impl Step1 {
    /// Step 1 (paper 2.3.2): direct light on the boundary (and interior patches when
    /// `direct_on_interior`), and the punctual lights' on every patch. The paper recomputes
    /// it every frame; here it is cached with its shadow rays ([`DirectCache`],
    /// [`PunctualCache`]): when only occluders moved, only the shadow rays that meet a box
    /// they swept are re-traced (exactly what a full recomputation would give); a light
    /// surface that moved or changed recomputes the light surfaces' part, a punctual light
    /// that moved re-traces its own term and one that changed strength only rescales it.
    ///
    /// What moved is taken from [`DirectSync`]: every object that moved since Step 1 last
    /// ran, from where it was then to where it is now, so a Step 1 carried over frames by a
    /// budget's deadline catches up exactly. `lit`: the objects Step 2 lights this frame,
    /// the only movers whose own patches' held light is read ([`DirectCache::update`]).
    pub(super) fn direct_to_boundary(
        &mut self,
        world: &World,
        (changes, lit): (&Changes, &[u32]),
        (options, now): (&DispersiveOptions, ObjectPlaces),
    ) {
        // A frame without changes still traces, with every sample, the receivers a mover
        // left with fewer (`coarse_while_moving`).
        if self.direct_valid
            && self.direct_sync.moved.is_empty()
            && !changes.light_changed()
            && !self.direct_cache.catching_up()
            && !self.punctual.catching_up()
        {
            return;
        }
        let p = &world.patches;
        let moved = std::mem::take(&mut self.direct_sync.moved);
        let surface_changed = !changes.relit.is_empty() || moved.iter().any(|&o| emits(world, o));
        let samples = options.direct_samples.max(1);
        let everything = !self.direct_valid;
        // A moving receiver with a quarter of the samples (`coarse_while_moving`).
        let moving_samples = match options.coarse_while_moving {
            true => samples.div_ceil(4),
            false => samples,
        };
        let places = self.direct_sync.moved_places(&moved, now);
        let moves = places.moves();
        let parts = &mut self.punctual;
        parts.area.resize(p.len(), Vec3::ZERO);
        let mut changed: Vec<u32> = Vec::new();
        // The cache's receivers whose light it recomputed (None: all of them).
        let mut recomputed: Option<Vec<usize>> = None;
        if everything
            || surface_changed
            || self.direct_cache.samples() != samples
            || !self.direct_cache.same_emitters(world)
        {
            let receivers: Vec<u32> = (0..p.len() as u32)
                .into_par_iter()
                .filter(|&i| match p.role(i as usize) {
                    Role::Boundary | Role::Light => true,
                    Role::Interior => options.direct_on_interior,
                })
                .filter(|&i| world.reflectance[i as usize].max_element() > 0.0)
                .collect();
            self.direct_cache = DirectCache::new(world, receivers, samples);
            changed.extend(self.direct_cache.receivers());
        } else if !moved.is_empty() || self.direct_cache.catching_up() {
            let movers: Vec<u32> = moved.iter().map(|&o| o as u32).collect();
            let ks = self.direct_cache.update(
                world,
                (&movers, lit),
                moves,
                moving_samples,
                MOVING_STRIDE,
            );
            changed.extend(ks.iter().map(|&k| self.direct_cache.receivers()[k]));
            recomputed = Some(ks);
        }
        let (receivers, e) = (
            self.direct_cache.receivers(),
            self.direct_cache.irradiance(),
        );
        match recomputed {
            // Only what the update changed: a pass over the 1M-patch room's receivers cost
            // more than the update of a small mover.
            Some(ks) => ks
                .into_iter()
                .for_each(|k| parts.area[receivers[k] as usize] = e[k]),
            None => (receivers.iter().zip(e)).for_each(|(&i, &e)| parts.area[i as usize] = e),
        }
        let rebuild = everything || parts.receivers_changed(world, &changes.relit);
        // A mover's patches are read (Step 2) only in a frame that lights it.
        let read = |i: u32| lit.contains(&p.object[i as usize]);
        // A moved object's patches moved themselves: traced again when read (with
        // `moving_samples` while they move), and whole once they rest.
        let movers = (&moved[..], moving_samples);
        changed.extend(parts.update(world, (rebuild, samples), moves, (movers, read)));
        changed.par_sort_unstable();
        changed.dedup();
        for i in changed {
            let i = i as usize;
            self.direct[i] = parts.area[i] + parts.by_patch.get(i).copied().unwrap_or(Vec3::ZERO);
            self.touched.patch(i);
        }
        self.direct_valid = true;
        self.direct_sync
            .in_sync((!everything).then_some(&moved[..]), now);
    }
}

/// Where the objects that moved since Step 1 last ran were then and are now, as boxes and
/// spheres (aligned with them).
struct MovedPlaces {
    old: Vec<Aabb>,
    new: Vec<Aabb>,
    was: Vec<Option<Sphere>>,
    is: Vec<Option<Sphere>>,
}

impl MovedPlaces {
    /// The move, as the caches take it.
    fn moves(&self) -> Moves<'_> {
        Moves {
            old: &self.old,
            new: &self.new,
            was: &self.was,
            is: &self.is,
        }
    }
}

/// What Step 1 last saw, so that it can be carried to a later frame (a budget's deadline)
/// and then catch up exactly: a shadow ray's outcome can only have changed if its segment
/// meets where a mover was when Step 1 last ran (a blocker gone) or where it is now (a new
/// blocker); where it passed in between does not matter.
#[derive(Clone, Debug, Default)]
pub(super) struct DirectSync {
    /// Every object's world box when Step 1 last ran.
    pub(super) boxes: Vec<Aabb>,
    /// Every object's sphere ([`crate::Patches::world_sphere`]) when Step 1 last ran: a
    /// mover's shadow rays are found by its box and its sphere there (`mover_spheres.rs`).
    pub(super) spheres: Vec<Option<Sphere>>,
    /// The objects that moved since, in the order they first moved.
    pub(super) moved: Vec<usize>,
    /// Whether the last frame carried Step 1 over (the next one runs it).
    pub(super) carried: bool,
    /// Measured cost of Step 1 at its last run with a mover (ms), for the deadline.
    pub(super) cost_ms: f64,
}

impl DirectSync {
    /// Where `moved` were when Step 1 last ran, and are `now`.
    fn moved_places(&self, moved: &[usize], (boxes, spheres): ObjectPlaces) -> MovedPlaces {
        MovedPlaces {
            old: moved.iter().map(|&o| self.boxes[o]).collect(),
            new: moved.iter().map(|&o| boxes[o]).collect(),
            was: (moved.iter())
                .map(|&o| self.spheres.get(o).copied().flatten())
                .collect(),
            is: moved.iter().map(|&o| spheres[o]).collect(),
        }
    }

    /// Step 1 now has the objects `moved` (every object: `None`) where they are `now`.
    fn in_sync(&mut self, moved: Option<&[usize]>, (boxes, spheres): ObjectPlaces) {
        match moved {
            None => {
                self.boxes = boxes.to_vec();
                self.spheres = spheres.to_vec();
            }
            Some(moved) => moved.iter().for_each(|&o| {
                self.boxes[o] = boxes[o];
                self.spheres[o] = spheres[o];
            }),
        }
    }
}

/// Step 1's punctual lights: their cached direct light and, per patch, its value and the
/// light surfaces' (`direct` is the sum of the two).
#[derive(Clone, Debug, Default)]
pub(super) struct PunctualDirect {
    cache: PunctualCache,
    /// Per patch: the punctual lights' direct irradiance (empty without punctual lights).
    by_patch: Vec<Vec3>,
    /// Per patch: the light surfaces' direct irradiance.
    area: Vec<Vec3>,
}

impl PunctualDirect {
    /// `changes` with every punctual light whose state differs from the one traced added to
    /// [`Changes::lights`] (however it changed: the engine, the time, a caller of its own).
    pub(super) fn with_light_changes(&self, world: &World, changes: &Changes) -> Changes {
        let mut out = changes.clone();
        for (l, now) in world.lights.iter().enumerate() {
            if self.cache.lights().get(l) != Some(now) && !out.lights.contains(&l) {
                out.lights.push(l);
            }
        }
        // The sky is light `lights.len()` (a sky change is a light change).
        let sky = world.lights.len();
        if !self.cache.same_sky(world) && !out.lights.contains(&sky) {
            out.lights.push(sky);
        }
        out
    }

    /// Whether patches that moved wait to have their punctual light traced (they are once
    /// they rest: a frame without a mover then runs Step 1).
    pub(super) fn catching_up(&self) -> bool {
        self.cache.catching_up()
    }

    /// Whether a patch of the `relit` objects began or ceased to reflect (a reflectance set
    /// to or from 0): the cache's receivers are the patches that reflect.
    fn receivers_changed(&self, world: &World, relit: &[usize]) -> bool {
        let receivers = self.cache.receivers();
        relit.iter().any(|&o| {
            world.patches.range(o).any(|i| {
                let reflects = world.reflectance[i].max_element() > 0.0;
                reflects != receivers.binary_search(&(i as u32)).is_ok()
            })
        })
    }

    /// Bring the punctual part up to date (whole when `everything`, or the sample count or
    /// the number of lights changed; a moved patch when `read` says its light is read after
    /// this update, or once it rests: [`PunctualCache::update`]); returns the patches whose
    /// value changed.
    fn update(
        &mut self,
        world: &World,
        (everything, samples): (bool, u32),
        moves: Moves,
        (moved, read): ((&[usize], u32), impl Fn(u32) -> bool + Sync),
    ) -> Vec<u32> {
        let p = &world.patches;
        if !crate::lights::has_sources(world) {
            let had: Vec<u32> = (0..self.by_patch.len() as u32).collect();
            self.by_patch.clear();
            return had;
        }
        let ks = if everything
            || self.by_patch.len() != p.len()
            || self.cache.samples() != samples
            || !self.cache.same_lights(world)
        {
            // Every patch that reflects: a probe cannot see a punctual light, so interior
            // patches take it here whatever `direct_on_interior` says.
            let receivers: Vec<u32> = (0..p.len() as u32)
                .filter(|&i| world.reflectance[i as usize].max_element() > 0.0)
                .collect();
            self.cache = PunctualCache::new(world, receivers, samples);
            self.by_patch = vec![Vec3::ZERO; p.len()];
            (0..self.cache.receivers().len()).collect()
        } else {
            self.cache.update(world, moves, moved, read)
        };
        let (receivers, e) = (self.cache.receivers(), self.cache.irradiance());
        ks.iter()
            .map(|&k| {
                self.by_patch[receivers[k] as usize] = e[k];
                receivers[k]
            })
            .collect()
    }
}
