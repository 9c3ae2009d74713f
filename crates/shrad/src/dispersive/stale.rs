//! Which cached rays of Steps 2 and 3 (`caches.rs`) a mover made stale, found lazily: a
//! frame only logs the boxes its movers swept ([`SweptLog`]), and an object's caches are
//! checked against what was swept since its last check just before it is updated. A frame
//! then costs the objects it updates, not every object in the scene (issue 24: a mover's
//! cost must not grow with the number of objects it does not touch).
//!
//! The result is the one an eager check every frame gives: between two updates of an object
//! its cached rays do not change, and a ray is stale exactly when one of the boxes swept
//! since it was cast meets it, in whatever order the boxes are tested. Only when the log
//! overflows ([`SWEPT_LOG_CAP`] frames with movers since the stalest object's check) are the
//! oldest frames merged into the box that holds them, which forgets more rays than needed
//! (they are cast again), never fewer.

use std::collections::VecDeque;

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::{Aabb, Role};

use super::caches::{
    mark_stale, ChunkCones, EmitterCache, EmitterRays, ProbeCache, RAY_UNKNOWN, SEES_STALE, UNKNOWN,
};
use super::object_state::ObjectProbes;
use super::swept_boxes::SweptBoxes;
use super::{Changes, Dispersive, DispersiveOptions};
use crate::direct::mover_spheres::{padded, SweptBox};
use crate::World;

/// Frames with movers kept apart in the log at most.
pub(super) const SWEPT_LOG_CAP: usize = 64;

/// What moved in one frame.
#[derive(Clone, Debug)]
pub(super) struct Swept {
    /// The frame it moved in.
    frame: u64,
    /// The boxes the movers swept (old and new places), padded for rounding, each with a
    /// sphere about its mover there where it is known (`direct/mover_spheres.rs`).
    boxes: Vec<SweptBox>,
    /// The objects that moved (scene indices).
    moved: Vec<usize>,
    /// A boundary or light object moved: every Step 3 cache aims at its patches.
    boundary_moved: bool,
}

/// The frames with movers since the stalest object's caches were checked.
#[derive(Default)]
pub(super) struct SweptLog {
    frames: VecDeque<Swept>,
}

impl SweptLog {
    /// Log this frame's movers (nothing when nothing moved).
    fn push(&mut self, swept: Swept) {
        self.frames.push_back(swept);
        while self.frames.len() > SWEPT_LOG_CAP {
            let (a, b) = (self.frames.pop_front(), self.frames.pop_front());
            let (Some(a), Some(b)) = (a, b) else { break };
            let all = a.boxes.iter().chain(&b.boxes);
            let union = all.fold(Aabb::EMPTY, |u, x| u.union(x.0));
            let mut moved = a.moved;
            for o in b.moved {
                if !moved.contains(&o) {
                    moved.push(o);
                }
            }
            self.frames.push_front(Swept {
                frame: b.frame,
                boxes: vec![(union, None)],
                moved,
                boundary_moved: a.boundary_moved || b.boundary_moved,
            });
        }
    }

    /// What moved after `frame`, merged: (boxes with spheres, movers, a boundary object
    /// moved).
    fn since(&self, frame: Option<u64>) -> (Vec<SweptBox>, Vec<usize>, bool) {
        let after = self
            .frames
            .iter()
            .filter(|s| frame.is_none_or(|f| s.frame > f));
        let (mut boxes, mut moved, mut boundary) = (Vec::new(), Vec::new(), false);
        for s in after {
            // One mover's new box of a frame is its old box of the next: test it once.
            for b in &s.boxes {
                if !boxes.contains(b) {
                    boxes.push(*b);
                }
            }
            moved.extend_from_slice(&s.moved);
            boundary |= s.boundary_moved;
        }
        (boxes, moved, boundary)
    }

    /// Drop the frames every object has been checked past (an object never checked has no
    /// cache yet: it is checked before its first update fills one).
    fn trim(&mut self, checked: impl Iterator<Item = Option<u64>>) {
        let Some(oldest) = checked.flatten().min() else {
            return;
        };
        while self.frames.front().is_some_and(|s| s.frame <= oldest) {
            self.frames.pop_front();
        }
    }
}

impl Dispersive {
    /// Log the boxes this frame's movers swept (old and new places, in pairs, each with a
    /// sphere about the mover there), to be checked against each object's caches when it is
    /// next updated.
    pub(super) fn log_swept(&mut self, world: &World, changes: &Changes, swept: &[SweptBox]) {
        if changes.moved.is_empty() {
            return;
        }
        let p = &world.patches;
        // The scene's size from the objects' boxes (kept current as they move): the scene's
        // own bounds transform every mesh of the scene again, a pass over every vertex in
        // each moving frame.
        let all = (self.object_boxes.iter()).fold(Aabb::EMPTY, |u, b| u.union(*b));
        let diag = if all.is_empty() { 1.0 } else { all.diagonal() };
        // A hit on a mover's surface lies on its box up to rounding.
        let pad = 4.0 * world.eps + 1e-5 * diag;
        self.swept_log.push(Swept {
            frame: self.frame,
            boxes: swept.iter().map(|&b| padded(b, pad)).collect(),
            moved: changes.moved.clone(),
            boundary_moved: changes
                .moved
                .iter()
                .any(|&o| p.object_role[o] != Role::Interior),
        });
    }

    /// Forget the cached rays of the objects about to be updated (`batch`, indices into the
    /// interior objects) that something swept since their last check; with the caches off,
    /// forget everything they hold.
    pub(super) fn forget_stale_caches(&mut self, world: &World, batch: &[usize]) {
        for &k in batch {
            let checked = self.objects[k].checked_frame.replace(self.frame);
            if !self.caching {
                let ob = &mut self.objects[k];
                ob.probe_cache = ProbeCache::default();
                ob.emitter_cache = EmitterCache::default();
                ob.probe_vis.forget();
                // A coarse mover's openness is not a cache but its stand-in until it rests
                // (`note_changes`).
                if !(ob.moving && self.options.coarse_while_moving) {
                    ob.forget_openness();
                }
                continue;
            }
            let (boxes, moved, boundary_moved) = self.swept_log.since(checked);
            if boxes.is_empty() {
                continue;
            }
            let swept = SweptBoxes::new(&boxes);
            let test = StaleTest {
                spheres: swept.spheres(),
                swept,
                probe_dirs: &self.camera.cube.directions,
                probe_cones: &self.probe_cones,
                emitter_dirs: &self.emitter_camera.cube.directions,
                emitter_cones: &self.emitter_cones,
                object_boxes: &self.object_boxes,
                options: &self.options,
            };
            let ob = &mut self.objects[k];
            if moved.contains(&ob.object) {
                ob.probe_cache = ProbeCache::default();
                ob.emitter_cache = EmitterCache::default();
                ob.probe_vis.forget();
                continue;
            }
            test.forget_openness(world, ob);
            test.forget_probe_visibility(world, ob);
            test.forget_probe_rays(ob);
            if boundary_moved {
                ob.emitter_cache = EmitterCache::default();
            } else {
                test.forget_emitter_rays(world, ob);
            }
        }
        let checked = self.objects.iter().map(|ob| ob.checked_frame);
        self.swept_log.trim(checked);
    }
}

/// The swept boxes one object's caches are checked against, with what the tests need.
struct StaleTest<'a> {
    swept: SweptBoxes,
    /// Spheres that hold the boxes (centre, radius), for the chunks' cones.
    spheres: Vec<(Vec3, f32)>,
    /// The probes' and emitters' texel directions and chunk cones (`caches.rs`).
    probe_dirs: &'a [Vec3],
    probe_cones: &'a ChunkCones,
    emitter_dirs: &'a [Vec3],
    emitter_cones: &'a ChunkCones,
    /// Every object's world box now.
    object_boxes: &'a [Aabb],
    /// The settings (the near field's reach).
    options: &'a DispersiveOptions,
}

impl StaleTest<'_> {
    /// Whether the segment from `o` along `d` for `t` (in units of `d`) meets a box.
    fn meets(&self, o: Vec3, d: Vec3, t: f32) -> bool {
        self.swept.meet(o, d, t)
    }

    /// Contact openness looks a short reach (`contact_openness`) beyond the object's own
    /// surface: only a mover whose box comes within that reach can change it.
    /// A measured near field is forgotten only at the patches a box comes within reach of
    /// (each patch's near field is its own rays within that reach); they are measured again
    /// at the object's next updates (`Dispersive::measure_openness`).
    /// A patch that sees the void looks beyond the reach too: it is forgotten where a box
    /// meets one of those rays ([`super::near_field::NearField::far_stale`]).
    fn forget_openness(&self, world: &World, ob: &mut ObjectProbes) {
        let reach = super::near_field::near_reach(self.options, world, ob.object, &ob.probe_box);
        let near = self.object_boxes[ob.object].padded(Vec3::splat(reach + 2.0 * world.eps));
        let p = &world.patches;
        let range = p.range(ob.object);
        let far = ob
            .near
            .far_stale(world, range.clone(), |o, d| self.meets(o, d, 1.0));
        if far.is_empty() && !self.swept.boxes().any(|b| b.meets_box(&near)) {
            return;
        }
        let measured = !ob.near.lobe.is_empty() && ob.near_pending.is_none();
        if !(measured && (ob.openness_current || !ob.near_stale.is_empty())) {
            ob.forget_openness();
            return;
        }
        let within = |i: usize| {
            let (c, r) = (p.centre[i], p.radius(i) + reach + 4.0 * world.eps);
            (self.swept.boxes()).any(|b| (c.clamp(b.min, b.max) - c).length_squared() <= r * r)
        };
        let stale = (range.clone())
            .filter(|&i| within(i))
            .map(|i| (i - range.start) as u32);
        ob.near_stale.extend(stale.chain(far));
        ob.near_stale.sort_unstable();
        ob.near_stale.dedup();
        if !ob.near_stale.is_empty() {
            ob.openness_current = false;
        }
    }

    /// Mark stale the patch-to-probe segments a box meets (`probe_visibility.rs`).
    fn forget_probe_visibility(&self, world: &World, ob: &mut ObjectProbes) {
        let probe_box = ob
            .probe_box
            .transformed(world.patches.world_from_local[ob.object]);
        let boxes: Vec<Aabb> = self.swept.boxes().copied().collect();
        (ob.probe_vis).forget_where(world, (ob.object, &probe_box), &boxes, |from, to| {
            self.meets(from, to - from, 1.0)
        });
    }

    /// Mark stale the probe texels whose rays a box meets (the probes in parallel).
    fn forget_probe_rays(&self, ob: &mut ObjectProbes) {
        let (dirs, cones) = (self.probe_dirs, self.probe_cones);
        ob.probe_cache
            .probes
            .par_iter_mut()
            .flatten()
            .for_each(|h| {
                let (origin, seen) = (h.origin, ChunkCones::seen_from(h.origin, &self.spheres));
                let (marks, t) = (&mut h.seen, &h.t);
                let marked = mark_stale(cones, &seen, marks, SEES_STALE, |k| {
                    self.meets(origin, dirs[k], t[k])
                });
                h.stale.extend(marked.into_iter().map(|k| k as u32));
            });
    }

    /// Forget the Step 3 rays a box meets (the emitters in parallel).
    fn forget_emitter_rays(&self, world: &World, ob: &mut ObjectProbes) {
        let p = &world.patches;
        let (emitter_dirs, emitter_cones) = (self.emitter_dirs, self.emitter_cones);
        ob.emitter_cache
            .rays
            .par_iter_mut()
            .for_each(|rays| match rays {
                EmitterRays::Gather(g) => {
                    let c = g.centre;
                    let seen = ChunkCones::seen_from(c, &self.spheres);
                    let from_before = g.forgotten.len();
                    for e in g.cones.meeting(&seen).flat_map(|k| g.cones.chunk(k)) {
                        let j = g.patch[e] as usize;
                        let from = p.centre[j] + p.normal[j] * world.eps;
                        if g.ray[e] != RAY_UNKNOWN && self.meets(from, c - from, 1.0) {
                            g.forgotten.push((e as u32, g.ray[e]));
                            g.ray[e] = RAY_UNKNOWN;
                        }
                    }
                    // In the entries' order, as `resend.rs` sends them (a tile's are not).
                    g.forgotten[from_before..].sort_unstable_by_key(|&(e, _)| e);
                }
                EmitterRays::Splat(s) => {
                    let c = s.centre;
                    let seen = ChunkCones::seen_from(c, &self.spheres);
                    let t = &s.t;
                    let forgotten = mark_stale(emitter_cones, &seen, &mut s.seen, UNKNOWN, |k| {
                        self.meets(c, emitter_dirs[k], t[k])
                    });
                    s.forgotten.extend(forgotten.into_iter().map(|k| k as u32));
                }
            });
    }
}
