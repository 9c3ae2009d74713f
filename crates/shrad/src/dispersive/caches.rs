//! What Steps 2 and 3 keep of an object's *geometry* between its updates, so that a frame in
//! which nothing moved near it only re-reads radiosity (paper 2.3.3 and 2.3.4 recompute it
//! all every update; the result is the same, only cheaper).
//!
//! - Step 2: for each of its 8 probes, which patch each cube-map texel sees (or that it sees
//!   nothing, or a back face) and how far, at the probe's current place.
//! - Step 3 gather: for each emitter, the boundary patches that face it, with `cos`, `r^2`,
//!   the direction towards them and whether the shadow ray to them is blocked (cast lazily:
//!   only once the emitter's intensity towards the patch is positive, as the uncached
//!   gather does).
//! - Step 3 splat: for each emitter, the patch each texel of its cube map lands on, traced
//!   lazily in the same way.
//! - Both: each emitting patch's lobe-weighted SH basis along its world exit direction.
//!
//! Everything is exact: a cached ray is forgotten when the object moves, when its probes
//! move, and when a box swept by another object (its old or new place, padded) meets the
//! ray's segment (`stale.rs`, a per-ray slab test, checked just before the object is updated); a ray that was
//! forgotten is cast again the next time it is needed. A moving boundary or light object
//! (whose patches Step 3 aims at) forgets every Step 3 cache. Options never change under a
//! solver without a rebuild (`set_schedule` changes only the schedule, which the caches do
//! not depend on), so they need no check. A light that changes emission changes radiance,
//! which is read afresh at every update, so it forgets nothing. Sizes are bounded per object
//! ([`MAX_PROBE_BYTES`], [`MAX_STEP3_BYTES`]): beyond them an object is not cached. The
//! tests below run moves (a teleport and back, a light moved and dimmed) with the caches on
//! and off (`Dispersive::set_caching`) and compare the radiosity frame by frame.

use glam::{Affine3A, Vec3};
use shrad_sh::ShRgb;

pub(super) use super::chunk_cones::{ChunkCones, SeenSphere};
use super::Dispersive;

/// A probe texel that sees nothing to shade: a miss, or the object's own black texel.
pub(super) const SEES_NOTHING: u32 = u32::MAX;
/// A probe texel that sees a back face (or the outside of the enclosure).
pub(super) const SEES_BACK: u32 = u32::MAX - 1;
/// A probe texel a mover's box may have changed: traced again before the probe is shaded.
pub(super) const SEES_STALE: u32 = u32::MAX - 2;
/// A splat texel not traced since it was last forgotten.
pub(super) const UNKNOWN: u32 = u32::MAX;
/// A splat texel whose ray lands on no patch.
pub(super) const LANDS_NOWHERE: u32 = u32::MAX - 1;

/// A gather entry's shadow ray, not cast yet.
pub(super) const RAY_UNKNOWN: u8 = 0;
/// A gather entry whose shadow ray is clear.
pub(super) const RAY_CLEAR: u8 = 1;
/// A gather entry whose shadow ray is blocked.
pub(super) const RAY_BLOCKED: u8 = 2;

/// Above this a Step 3 cache is not kept (it is built, used and dropped each update, which
/// is what the uncached code costs): 24 MiB an object. Measured with both caches
/// (`examples/cache_memory.rs`): the Cornell box at 20k patches holds 2.8 MB an object
/// (gather: about 110k facing (emitter, patch) entries of 25 bytes, plus 0.4 MB of probe
/// hits), the 77k room 1.7 MB an object (splat: 6 x 24576 texels of 8 bytes).
pub(super) const MAX_STEP3_BYTES: usize = 24 << 20;

/// Above this an object's probe hits are not kept (8 bytes a texel: 0.4 MB at the default
/// 32^2 faces, 6.3 MB at the paper's 128^2, 25 MB at 256^2, which is not kept).
pub(super) const MAX_PROBE_BYTES: usize = 8 << 20;

/// Mark `stale` every ray of `marks` in a chunk of `cones` that may meet a `seen` sphere
/// and that `meets` says a mover's box meets (skipping those already marked); returns the
/// rays marked.
pub(super) fn mark_stale(
    cones: &ChunkCones,
    seen: &[SeenSphere],
    marks: &mut [u32],
    stale: u32,
    meets: impl Fn(usize) -> bool,
) -> Vec<usize> {
    let mut out = Vec::new();
    for c in cones.meeting(seen) {
        for k in cones.chunk(c) {
            if marks[k] != stale && meets(k) {
                marks[k] = stale;
                out.push(k);
            }
        }
    }
    out
}

/// What a probe's capture at its current place saw.
pub(super) struct ProbeHits {
    /// Where it was captured (world).
    pub(super) origin: Vec3,
    /// Per texel: the patch seen, [`SEES_NOTHING`], [`SEES_BACK`] or [`SEES_STALE`].
    pub(super) seen: Vec<u32>,
    /// Per texel: the hit distance (infinite for a miss).
    pub(super) t: Vec<f32>,
    /// Fraction of the sphere (by solid angle) that sees back faces (stale texels aside).
    pub(super) back_fraction: f32,
    /// The texels marked [`SEES_STALE`], to trace again: a mover usually covers a small
    /// part of a neighbour's probe, so only that part is re-captured.
    pub(super) stale: Vec<u32>,
}

/// Step 2's cache of one object.
#[derive(Default)]
pub(super) struct ProbeCache {
    /// The object's transform and probe places the hits belong to.
    pub(super) key: Option<(Affine3A, [glam::Vec3; 8])>,
    /// Per probe; `None`: to capture again. A probe `MoveInward` could not repair is never
    /// kept: its outcome depends on the failed captures too.
    pub(super) probes: [Option<ProbeHits>; 8],
}

/// The boundary patches one gather emitter faces, in boundary order (see the module docs).
pub(super) struct GatherEntries {
    pub(super) centre: Vec3,
    pub(super) patch: Vec<u32>,
    pub(super) cos: Vec<f32>,
    pub(super) r2: Vec<f32>,
    /// The direction from the emitter to each entry's patch (x, y and z apart).
    pub(super) dir: [Vec<f32>; 3],
    /// [`RAY_UNKNOWN`], [`RAY_CLEAR`] or [`RAY_BLOCKED`].
    pub(super) ray: Vec<u8>,
    /// The cone of each tile of entries' directions from the centre (`ChunkCones::by_direction`).
    pub(super) cones: ChunkCones,
    /// The entries the stale test forgot since the boundary's contribution was sent, with
    /// their ray as it was then (`resend.rs`: the light paths a mover crossed).
    pub(super) forgotten: Vec<(u32, u8)>,
    /// The factor the contribution the boundary holds was rescaled by (the softening's,
    /// [`Dispersive::gather`](super::Dispersive)), which an amendment keeps.
    pub(super) sent_scale: f32,
}

/// The texels of one splat emitter.
pub(super) struct SplatTexels {
    pub(super) centre: Vec3,
    /// Per texel: the patch it lands on, [`LANDS_NOWHERE`] or [`UNKNOWN`].
    pub(super) seen: Vec<u32>,
    /// Per texel: the hit distance (infinite for a miss).
    pub(super) t: Vec<f32>,
    /// Per texel: the boundary patch its flux went to in the contribution the boundary
    /// holds, or [`LANDS_NOWHERE`] (`resend.rs`).
    pub(super) sent_to: Vec<u32>,
    /// The texels the stale test forgot since the boundary's contribution was sent
    /// (`stale.rs`): the light paths a mover crossed, which `resend.rs` sends alone.
    pub(super) forgotten: Vec<u32>,
}

impl SplatTexels {
    /// `n` texels from `centre`, none traced yet.
    pub(super) fn new(centre: Vec3, n: usize) -> SplatTexels {
        SplatTexels {
            centre,
            seen: vec![UNKNOWN; n],
            t: vec![f32::INFINITY; n],
            sent_to: vec![LANDS_NOWHERE; n],
            forgotten: Vec::new(),
        }
    }
}

/// How one emitter reaches the boundary.
pub(super) enum EmitterRays {
    Gather(Box<GatherEntries>),
    Splat(SplatTexels),
}

/// Step 3's cache of one object.
#[derive(Default)]
pub(super) struct EmitterCache {
    /// The object's transform the cache belongs to.
    pub(super) key: Option<Affine3A>,
    /// Per emitter, per member patch: `nc` values `A_l Y_k(d_i)` along its world exit
    /// direction (2.3.4 Step 1).
    pub(super) lobes: Vec<Vec<f32>>,
    /// Per emitter.
    pub(super) rays: Vec<EmitterRays>,
    /// Per emitter, the intensity the boundary's contribution was sent with (empty when it
    /// was not sent from these emitters); and that contribution's length (`resend.rs`).
    pub(super) sent: Vec<ShRgb>,
    pub(super) sent_len: usize,
    /// The emitters, in order, whose rays were traced ahead of an update (`prepare.rs`), or
    /// for the light the last update sent.
    pub(super) prepared: usize,
}

impl ProbeCache {
    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        self.probes
            .iter()
            .flatten()
            .map(|h| h.seen.len() * 4 + h.t.len() * 4)
            .sum()
    }
}

impl EmitterCache {
    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        let lobes: usize = self.lobes.iter().map(|l| l.len() * 4).sum();
        let rays: usize = self
            .rays
            .iter()
            .map(|r| match r {
                EmitterRays::Gather(g) => {
                    g.patch.len() * 25 + g.cones.bytes() + g.forgotten.len() * 8
                }
                EmitterRays::Splat(s) => s.seen.len() * 12 + s.forgotten.len() * 4,
            })
            .sum();
        lobes + rays
    }
}

impl Dispersive {
    /// Bytes the Step 2 and Step 3 caches hold now, over all objects.
    pub fn cache_bytes(&self) -> usize {
        self.objects
            .iter()
            .map(|ob| ob.probe_cache.bytes() + ob.emitter_cache.bytes())
            .sum()
    }

    /// Keep Steps 2 and 3's rays between updates (the default) or cast them all again at
    /// every update: the results are the same (a test checks it), only slower.
    #[doc(hidden)]
    pub fn set_caching(&mut self, on: bool) {
        self.caching = on;
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Changes, DispersiveOptions, Schedule, ToBoundary};
    use super::*;
    use crate::patches::PatchSizing;
    use crate::World;
    use shrad_scene::Role;
    use shrad_vis::Backend;

    /// One frame's change to the Cornell box.
    enum Event {
        Still,
        /// Move the object to `offset` from its rest place.
        Move(&'static str, Vec3),
        /// Scale the light's emission.
        Relight(f32),
    }

    /// Run `events` on the Cornell box with the caches on and off; the radiosity must agree
    /// after every frame (to float-summation noise), and the cached run must have reused
    /// rays on the frames where nothing moved.
    fn same_with_and_without_caches(options: DispersiveOptions, events: &[Event]) {
        let scene = shrad_scene::cornell_box();
        let find = |name: &str| scene.objects.iter().position(|o| o.name == name).unwrap();
        let light = scene
            .objects
            .iter()
            .position(|o| o.role == Some(Role::Light))
            .unwrap();
        let light_emission = scene.objects[light].material.emitted_radiance;
        let mut runs: Vec<(World, Dispersive)> = [true, false]
            .into_iter()
            .map(|on| {
                let world =
                    World::new(scene.clone(), PatchSizing::Count(3000), Backend::Auto).unwrap();
                let mut d = Dispersive::new(&world, options).unwrap();
                d.set_caching(on);
                (world, d)
            })
            .collect();
        let (mut reused, mut retraced) = (0, 0);
        for (f, event) in events.iter().enumerate() {
            let changes = match *event {
                Event::Still => Changes::default(),
                Event::Move(name, offset) => {
                    let o = find(name);
                    let m = Affine3A::from_translation(offset) * scene.objects[o].world_from_object;
                    for (world, _) in &mut runs {
                        world.move_object(o, m).unwrap();
                    }
                    Changes {
                        moved: vec![o],
                        relit: vec![],
                        ..Default::default()
                    }
                }
                Event::Relight(s) => {
                    for (world, _) in &mut runs {
                        world.set_emission(light, light_emission * s).unwrap();
                    }
                    Changes {
                        moved: vec![],
                        relit: vec![light],
                        ..Default::default()
                    }
                }
            };
            let mut captured = [0; 2];
            for (r, (world, d)) in runs.iter_mut().enumerate() {
                let stats = d.step(world, &changes);
                captured[r] = stats.dispersive().unwrap().probes_captured;
                if r == 0 {
                    retraced += stats.dispersive().unwrap().probe_texels_retraced;
                }
            }
            if matches!(event, Event::Still | Event::Relight(_)) && f > 2 {
                assert!(captured[1] >= 8, "frame {f}: the uncached run captures");
                reused += usize::from(captured[0] == 0);
            }
            let (a, b) = (runs[0].1.radiosity(), runs[1].1.radiosity());
            let top = b.iter().map(|x| x.max_element()).fold(0f32, f32::max);
            let worst = a
                .iter()
                .zip(b)
                .map(|(x, y)| ((*x - *y).abs() / (y.abs() + Vec3::splat(1e-3 * top))).max_element())
                .fold(0f32, f32::max);
            assert!(
                worst <= 1e-5,
                "frame {f}: cached and uncached differ by {worst:e}"
            );
        }
        assert!(reused > 0, "the cache was never used");
        // The block's moves cross the other block's probes: only part of them is traced.
        assert!(retraced > 0, "no cached probe was refreshed texel by texel");
        assert!(runs[0].1.cache_bytes() > 0 && runs[1].1.cache_bytes() == 0);
    }

    fn moves() -> Vec<Event> {
        use Event::*;
        let x = Vec3::X;
        vec![
            Still,
            Still,
            Still,
            Still,
            Still,
            Move("short_block", 20.0 * x),
            Still,
            Still,
            Move("short_block", 40.0 * x),
            Still,
            // A teleport across the room, and back.
            Move("short_block", Vec3::new(-250.0, 0.0, 150.0)),
            Still,
            Still,
            Move("short_block", Vec3::ZERO),
            Still,
            Still,
            Relight(0.5),
            Still,
            Move("light", Vec3::new(30.0, -5.0, 20.0)),
            Still,
            Still,
            Move("tall_block", -30.0 * x),
            Still,
            Still,
            Still,
        ]
    }

    #[test]
    fn cached_gather_equals_uncached() {
        // Every object each frame: the still block is updated while the other moves, and
        // the amendment of its contribution (`resend.rs`) is not exact by design (it sends
        // the light of the last send, within `resend_tolerance`; it has its own tests).
        let options = DispersiveOptions {
            schedule: Schedule::Full,
            to_boundary: ToBoundary::Gather,
            resend_tolerance: 0.0,
            ..DispersiveOptions::improved()
        };
        same_with_and_without_caches(options, &moves());
    }

    #[test]
    fn cached_splat_equals_uncached_one_object_a_frame() {
        let options = DispersiveOptions {
            to_boundary: ToBoundary::Splat,
            ..DispersiveOptions::improved()
        };
        same_with_and_without_caches(options, &moves());
    }

    /// Probes that see through the objects within the near reach (the Cornell box's blocks
    /// are within each other's): a block's moves change what is near, and the cached
    /// probes and near fields follow.
    #[test]
    fn cached_equals_uncached_seeing_through_near_objects() {
        let options = DispersiveOptions {
            see_through_near: true,
            ..DispersiveOptions::improved()
        };
        same_with_and_without_caches(options, &moves());
    }
}
