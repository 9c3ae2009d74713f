//! The dispersive method of Wang, Liu and Wu (2007), spec section 4.
//!
//! Every interior object carries 8 SH light probes at the corners of its rest-frame bounding
//! box (expanded by a margin). A frame (paper 2.2) updates only the objects the scheduler
//! picks, in the paper's four steps, one file each:
//!
//! | step | paper | file |
//! |---|---|---|
//! | what changed; which objects this frame updates | 2.2, 2.3.3 Step 1 | `frame.rs`, `scheduler.rs` |
//! | 1. direct light on the boundary, cached until a light or an occluder moves | 2.3.2 | `step1_direct.rs` |
//! | 2. light the selected objects from their probes: capture, SH, trilinear, cosine lobe | 2.3.3 | `step2_probes.rs` |
//! | 3. each selected object lights the boundary as SH emitter(s), replacing its old share | 2.3.4 | `step3_to_boundary.rs` |
//! | 4. assemble the boundary's radiosity; energy meter and guard | 2.3.5 | `step4_assemble.rs` |
//!
//! The precomputation of 2.3.1 is [`Dispersive::new`], `object_state.rs` (probe boxes,
//! trilinear weights, exit directions) and `setup.rs` (what the steps share: the boundary,
//! object boxes, neighbourhoods, transfer vectors, emitter groups); the settings are
//! `options.rs`.
//!
//! Beyond the paper (spec 4.6), each switchable and measured against the reference in
//! `docs/results.md`: probe validity and repair, wall-to-wall exchange among the static
//! boundary patches, seeing through the object's own geometry when capturing, direct light on
//! interior patches computed explicitly (probes then carry reflected light only), and a
//! priority scheduler with a staleness bound and a time budget. `DispersiveOptions::paper()`
//! is the paper as written.

use std::time::Instant;

use glam::Vec3;
use shrad_scene::Role;

use crate::energy::IncidentMeter;
use crate::frame::{Changes, DispersiveStats, Divergence, EnergyBalance, FrameStats, SolverStats};
use crate::probes::ProbeCamera;
use crate::World;

mod caches;
mod chunk_cones;
mod frame;
mod gather;
pub mod inspect;
mod near_field;
mod near_rays;
mod object_state;
mod options;
mod prepare;
mod probe_visibility;
mod resend;
mod scheduler;
mod setup;
mod sleep;
mod spread;
mod stale;
mod step1_direct;
mod step2_batch;
mod step2_probes;
mod step3_to_boundary;
mod step4_assemble;
mod swept_boxes;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_incremental;
#[cfg(test)]
mod tests_near;
#[cfg(test)]
mod tests_prepare;
#[cfg(test)]
mod tests_settle;
mod touched;
mod wall_rows;

pub use frame::Batch;
pub use options::{DispersiveOptions, ProbeRepair, Schedule, ToBoundary};
pub use step3_to_boundary::splat_to_boundary;
pub use step4_assemble::{WALL_ROWS_DOZING, WALL_ROWS_PER_FRAME, WALL_ROWS_WHILE_MOVING};
pub use wall_rows::WALL_RETRACE_SHARE;

use object_state::ObjectProbes;
use object_state::{CrossedAhead, FirstObject, ObjectLight};
use scheduler::{Must, Scheduler};
use setup::{outer_sides, receives_as_boundary, world_box, Neighbours, LIGHT_METER_RAYS};
use step4_assemble::WallGather;
use wall_rows::WallRows;

/// The dispersive solver's state.
pub struct Dispersive {
    options: DispersiveOptions,
    /// Step 2's probes.
    camera: ProbeCamera,
    /// Step 3's splat from each emitter.
    emitter_camera: ProbeCamera,
    /// The cones of each chunk of the two cameras' texel directions (`caches.rs`).
    probe_cones: caches::ChunkCones,
    emitter_cones: caches::ChunkCones,
    /// Half-resolution probes and splat for objects that are moving
    /// (`coarse_while_moving`); never cached, so they need no cones.
    coarse_camera: ProbeCamera,
    coarse_emitter_camera: ProbeCamera,
    objects: Vec<ObjectProbes>,
    /// Which objects a frame updates; what it knows of each (aligned with `objects`).
    scheduler: Scheduler,
    /// Radiosity of every patch.
    radiosity: Vec<Vec3>,
    /// Direct irradiance (boundary, and interior when `direct_on_interior`).
    direct: Vec<Vec3>,
    /// Irradiance of interior patches from their probes.
    probe_irradiance: Vec<Vec3>,
    /// Sum over objects of their contributions to each boundary patch.
    indirect: Vec<Vec3>,
    /// One zero per patch: Step 3 sums its pieces here.
    scratch: Vec<Vec3>,
    /// Per patch, all false between uses: Step 3's spread marks the patches it reaches.
    reached: Vec<bool>,
    /// The boxes movers swept, until every object's caches were checked against them.
    swept_log: stale::SweptLog,
    /// Irradiance of boundary patches from other boundary patches.
    wall: Vec<Vec3>,
    /// Which chunks of patches the frame changed the light of (`touched.rs`).
    touched: touched::Touched,
    /// The energy meter's sums per chunk, and Step 4's `sum A B` over the boundary per chunk,
    /// as last computed (each frame computes those of the chunks touched).
    energy_chunks: Vec<crate::energy::Sums>,
    boundary_chunks: Vec<f64>,
    /// How many chunks the last meter summed again.
    chunks_metered: usize,
    /// The same, each row's own gather before `wall_smoothing` averages it over the
    /// patch's neighbours (empty when that is off).
    wall_gathered: Vec<Vec3>,
    /// Form-factor rows among boundary patches (aligned with `boundary_patches`), if the
    /// wall exchange is on.
    wall_rows: Option<WallRows>,
    boundary_patches: std::sync::Arc<[u32]>,
    /// Boundary patches next to each patch (itself included), for `splat_smoothing` and
    /// `wall_smoothing`.
    neighbours: Neighbours,
    /// World bounding box of every object at the last frame (to know where movers were).
    object_boxes: Vec<shrad_scene::Aabb>,
    /// Every object's sphere (`Patches::world_sphere`) where `object_boxes` has it.
    object_spheres: Vec<Option<crate::direct::mover_spheres::Sphere>>,
    /// Where the next frame's window of wall-exchange rows starts.
    wall_cursor: usize,
    direct_valid: bool,
    /// Step 1's direct light with its shadow rays, to re-trace only those a mover may block.
    direct_cache: crate::direct::DirectCache,
    /// Step 1's direct light of the punctual lights, likewise, and the light surfaces' part
    /// of `direct` apart.
    punctual: step1_direct::PunctualDirect,
    /// What Step 1 last saw (a budget's deadline may carry Step 1 to the next frame).
    direct_sync: step1_direct::DirectSync,
    /// Under a budget: the last frame updated no object because none fitted what was left,
    /// so this one updates one (and carries Step 1 over if it must): no object starves.
    objects_owed: bool,
    frame: u64,
    /// The reflected flux of the last frame within the bound (the guard lets the light held
    /// from before a light dimmed drain: [`crate::energy::over_bound`]).
    light_held: crate::energy::LightHeld,
    /// Irradiance of the lights that reflect nothing (kept at their emission), for the
    /// energy meter: what they absorb.
    light_meter: IncidentMeter,
    /// What this frame's guards found (moved into `FrameStats::diverged`).
    step_warnings: Vec<String>,
    /// Tests: panic inside the next frame's join, while Step 1's state is lent out.
    #[cfg(test)]
    pub(crate) fail_inside_join: bool,
    /// Per patch: the side of a double-sided boundary surface that faces away from the
    /// scene's centre, and of a double-sided interior object the side that faces its box
    /// centre. A probe that sees it is outside the enclosure or inside the object, like one
    /// that sees a single-sided back face (Blender exports every material double-sided by
    /// default, so without this a probe buried in the floor sees the floor's dark underside
    /// as valid).
    outer_side: Vec<bool>,
    /// Whether the scene is open to the outside: near-field rays that leave it see nothing,
    /// under a sky too (whose light Step 1 gives: `near_rays::is_open`).
    open: bool,
    /// Keep Steps 2 and 3's rays between updates (`caches.rs`); off only to test that they
    /// change nothing.
    caching: bool,
    /// Sleep and wake (`DispersiveOptions::sleep_tolerance`): the boundary's relative
    /// change summed over every frame so far (a sleeper wakes once it grew by more than the
    /// tolerance since it fell asleep)...
    drift: f64,
    /// ... each object's relative change at its last update (aligned with `objects`) ...
    object_change: Vec<f64>,
    /// ... and the frames in a row in which nothing changed, no object was updated and the
    /// walls' sweep changed the boundary by less than the tolerance: the walls sleep once
    /// that covers a whole sweep.
    quiet_frames: usize,
    /// ... and the boundary's relative change summed since Step 4's last whole window, that
    /// frame's own included: below the tolerance the walls doze (`sleep.rs`).
    wall_unswept: f64,
    /// The energy balance of the last frame that ran, for the frames that sleep.
    last_energy: EnergyBalance,
    /// Measured at the last frame, for a budget's deadline: Step 4 and the meter (ms), the
    /// meter alone (ms), and Step 4's cost per wall row (ms).
    tail_ms: f64,
    meter_ms: f64,
    row_ms: f64,
    /// Measured ms of the near field a patch (`near_field.rs`: its chunks under a budget).
    near_ms_per_patch: f64,
}

impl Dispersive {
    /// Precompute (paper 2.3.1): probe boxes, trilinear weights, exit directions, cube-map
    /// directions and SH weights; the wall exchange's form factors if enabled. `options` are
    /// taken as checked: [`crate::solver::Solver::new`] and the engine check every key
    /// against its range first (`SolverChoice::validate`, in `settings`, the layer above
    /// the solvers, so a solver never reaches back up to it); the presets are in range.
    pub fn new(world: &World, options: DispersiveOptions) -> Result<Dispersive, crate::Error> {
        Dispersive::new_with_progress(world, options, &crate::NoProgress)
    }

    /// [`Dispersive::new`], reporting each object's set-up and the wall rows to `progress`;
    /// [`crate::Error::Interrupted`] when it asks to stop (asked before each object and each
    /// chunk of wall rays).
    pub fn new_with_progress(
        world: &World,
        options: DispersiveOptions,
        progress: &dyn crate::Progress,
    ) -> Result<Dispersive, crate::Error> {
        let p = &world.patches;
        let coefficients = shrad_sh::num_coeffs(options.bands);
        crate::limits::check_cube_maps(options.cube_res, Some(options.emitter_res), coefficients)?;
        let camera = ProbeCamera::new(options.cube_res, options.bands);
        let emitter_camera = ProbeCamera::new(options.emitter_res, options.bands);
        let half = |res: usize| {
            if options.coarse_while_moving {
                (res / 2).max(1)
            } else {
                1
            }
        };
        let coarse_camera = ProbeCamera::new(half(options.cube_res), options.bands);
        let coarse_emitter_camera =
            ProbeCamera::new(half(options.emitter_res) * 3 / 4, options.bands);
        let interior: Vec<usize> = (0..world.scene.objects.len())
            .filter(|&o| p.object_role[o] == Role::Interior)
            .collect();
        let boundary_patches: Vec<u32> = (0..p.len() as u32)
            .filter(|&i| receives_as_boundary(world, i as usize))
            .collect();
        // Split emitters gather their near receivers (`setup::emitter_groups`); a splat
        // sends every emitter everywhere, so there they stay whole.
        let method = step3_to_boundary::method_for(
            options.to_boundary,
            boundary_patches.len(),
            emitter_camera.texels(),
        );
        let split = match method {
            ToBoundary::Gather => options.emitter_split,
            _ => 1,
        };
        progress.begin("setting up objects", interior.len() as u64);
        let objects: Result<Vec<ObjectProbes>, crate::Error> = interior
            .into_iter()
            .map(|o| {
                crate::progress::check(progress)?;
                let ob = ObjectProbes::new(world, o, &options, split);
                progress.advance(1);
                Ok(ob)
            })
            .collect();
        progress.end();
        let objects = objects?;
        // Rays that pass where an object moves are re-traced then (`WallRows::refresh`).
        let wall_rays = wall_rows::wall_rays_for(boundary_patches.len(), options.wall_rays);
        let wall_rows = options
            .wall_exchange
            .then(|| WallRows::new(world, &boundary_patches, wall_rays, false, progress))
            .transpose()?;
        let object_spheres: Vec<Option<crate::direct::Sphere>> = (0..world.scene.objects.len())
            .map(|o| world.patches.world_sphere(o))
            .collect();
        let object_boxes: Vec<shrad_scene::Aabb> = (0..world.scene.objects.len())
            .map(|o| world_box(world, o))
            .collect();
        let n = p.len();
        let n_objects = objects.len();
        let radiosity = world.exitance.clone();
        let probe_cones = caches::ChunkCones::tiles(&camera.cube);
        let emitter_cones = caches::ChunkCones::tiles(&emitter_camera.cube);
        Ok(Dispersive {
            options,
            camera,
            emitter_camera,
            coarse_camera,
            coarse_emitter_camera,
            probe_cones,
            emitter_cones,
            scheduler: Scheduler::new(options.schedule, objects.len()),
            objects,
            radiosity,
            direct: vec![Vec3::ZERO; n],
            probe_irradiance: vec![Vec3::ZERO; n],
            indirect: vec![Vec3::ZERO; n],
            scratch: vec![Vec3::ZERO; n],
            reached: vec![false; n],
            swept_log: Default::default(),
            wall: vec![Vec3::ZERO; n],
            touched: touched::Touched::new(n),
            energy_chunks: vec![([0.0; 5], 0.0); n.div_ceil(crate::energy::CHUNK)],
            boundary_chunks: vec![0.0; n.div_ceil(crate::energy::CHUNK)],
            chunks_metered: 0,
            wall_gathered: if options.wall_smoothing {
                vec![Vec3::ZERO; n]
            } else {
                Vec::new()
            },
            neighbours: if options.splat_smoothing || options.wall_smoothing {
                Neighbours::of_boundary(world)
            } else {
                Neighbours::default()
            },
            wall_rows,
            wall_cursor: 0,
            boundary_patches: boundary_patches.into(),
            direct_valid: false,
            direct_cache: Default::default(),
            punctual: Default::default(),
            direct_sync: step1_direct::DirectSync {
                boxes: object_boxes.clone(),
                spheres: object_spheres.clone(),
                ..Default::default()
            },
            objects_owed: false,
            frame: 0,
            light_held: Default::default(),
            light_meter: IncidentMeter::new(
                world,
                (0..p.len() as u32)
                    .filter(|&i| {
                        p.role(i as usize) == Role::Light
                            && !receives_as_boundary(world, i as usize)
                    })
                    .collect(),
                LIGHT_METER_RAYS,
            ),
            step_warnings: Vec::new(),
            #[cfg(test)]
            fail_inside_join: false,
            outer_side: outer_sides(world),
            open: options.near_rays > 0 && near_rays::is_open(world),
            caching: true,
            drift: 0.0,
            object_change: vec![f64::INFINITY; n_objects],
            object_boxes,
            object_spheres,
            quiet_frames: 0,
            wall_unswept: f64::INFINITY,
            last_energy: EnergyBalance::default(),
            tail_ms: 0.0,
            meter_ms: 0.0,
            row_ms: 0.0,
            near_ms_per_patch: 0.0,
        })
    }

    /// Current radiosity of every patch.
    pub fn radiosity(&self) -> &[Vec3] {
        &self.radiosity
    }

    /// The probe and splat cameras for an update of object `k` this frame: the coarse ones
    /// while it moves (`coarse_while_moving`), or when its full update is not prepared in
    /// time (`prepare.rs`).
    fn cameras_for(&self, k: usize) -> (&ProbeCamera, &ProbeCamera, bool) {
        let ob = &self.objects[k];
        if self.options.coarse_while_moving && (ob.moving || ob.coarse_now) {
            (&self.coarse_camera, &self.coarse_emitter_camera, true)
        } else {
            (&self.camera, &self.emitter_camera, false)
        }
    }

    /// The options in use.
    pub fn options(&self) -> &DispersiveOptions {
        &self.options
    }

    /// Change the schedule live (objects per frame, staleness bound, budget): it needs no
    /// precomputation, and every object keeps what the scheduler knows of it. A
    /// `per_frame` of 0 is taken as 1; a budget must be finite and positive.
    pub fn set_schedule(&mut self, schedule: Schedule) -> Result<(), crate::Error> {
        let schedule = match schedule {
            Schedule::RoundRobin { per_frame } => Schedule::RoundRobin {
                per_frame: per_frame.max(1),
            },
            Schedule::Priority {
                per_frame,
                max_staleness,
            } => Schedule::Priority {
                per_frame: per_frame.max(1),
                max_staleness,
            },
            Schedule::Budget { ms, .. } if !(ms.is_finite() && ms > 0.0) => {
                return Err(crate::Error::Invalid(format!(
                    "schedule budget {ms} ms must be a positive number"
                )))
            }
            s => s,
        };
        self.options.schedule = schedule;
        self.scheduler.set_schedule(schedule);
        Ok(())
    }

    /// The schedule in use.
    pub fn schedule(&self) -> Schedule {
        self.scheduler.schedule_in_use()
    }

    /// Number of interior objects.
    pub fn interior_objects(&self) -> usize {
        self.objects.len()
    }

    /// Frames in which the scheduler updates every object once on a static scene.
    pub fn frames_per_pass(&self) -> usize {
        self.scheduler.frames_per_pass()
    }

    /// One frame (paper 2.2): the world is already at the frame's time; `changes` says what
    /// moved or changed emission since the previous frame. A frame with work runs inside
    /// rayon's pool with the workers kept awake ([`crate::warm_pool`]): its many short
    /// parallel sections then start at once. A sleeping frame does not (waking the pool
    /// took it from 0.03 to 0.10 ms at 77k).
    pub fn step(&mut self, world: &World, changes: &Changes) -> FrameStats {
        let frame_start = Instant::now();
        self.set_up_again_if_receivers_changed(world, &changes.relit);
        let changes = &self.punctual.with_light_changes(world, changes);
        self.note_changes(world, changes);
        if self.everything_sleeps(changes) {
            return self.sleeping_frame(frame_start);
        }
        crate::warm_pool::warm(|| self.frame(world, changes, frame_start))
    }

    /// A light surface painted from black begins to receive light as the boundary does
    /// (`receives_as_boundary`), and one painted black ceases to. The boundary's receivers,
    /// on which the wall exchange, Step 3's emitters and the light meter are built, are
    /// chosen at set-up, so the set-up runs again and the light starts from the lights'
    /// emission, as after `Engine::set_solver` (else the painted light reflected nothing:
    /// `tests/reflectance.rs`). Any other change of colour keeps the set-up.
    fn set_up_again_if_receivers_changed(&mut self, world: &World, relit: &[usize]) {
        let p = &world.patches;
        let changed = relit.iter().any(|&o| {
            p.range(o).any(|i| {
                let listed = self.boundary_patches.binary_search(&(i as u32)).is_ok();
                receives_as_boundary(world, i) != listed
            })
        });
        if !changed {
            return;
        }
        match Dispersive::new(world, self.options) {
            Ok(fresh) => *self = fresh,
            Err(e) => (self.step_warnings).push(format!("set-up after a light was painted: {e}")),
        }
    }

    /// [`Dispersive::step`]'s frame once it has work.
    fn frame(&mut self, world: &World, changes: &Changes, frame_start: Instant) -> FrameStats {
        let rays_before = world.rays_cast();
        let mut stats = FrameStats::new(self.frame, SolverStats::Dispersive(Default::default()));
        let mut steps = DispersiveStats::default();
        // A budget is a deadline for the whole frame: the wall rows take a fifth of it, the
        // objects what is left after Step 1 and the expected cost of Step 4 and the meter
        // (`tail_ms`). Step 1 and an object that does not fit with it take turns.
        let budget_ms = match self.scheduler.schedule_in_use() {
            Schedule::Budget { ms, .. } => Some(ms as f64),
            _ => None,
        };
        let at = |share: f64| budget_ms.map(|b| frame_start + secs(b * share));
        // What a frame changed is marked as it is written (`touched.rs`); a frame without a
        // mover (unless the walls doze: `sleep.rs`), or with a light changed, meters and
        // assembles everything.
        let doze = self.walls_doze(changes);
        if (changes.moved.is_empty() && !doze) || changes.light_changed() {
            self.touched.everything();
        }
        let swept = self.swept_boxes(world, changes);
        self.log_swept(world, changes, &swept);
        let may_carry = self.may_carry_direct(world, changes);
        self.scheduler
            .note_something_moves(!changes.moved.is_empty());
        let (batch, over) = self.schedule_within(budget_ms, may_carry);
        // An object that goes although it does not fit takes Step 1's turn (when Step 1 may
        // wait) and the wall rows' fifth (they take their smallest step).
        let carry = over && may_carry;
        let walls_until = if over { Some(frame_start) } else { at(0.2) };

        // Full wall sweeps when the light changed; without a budget Step 4's gather is
        // known now and runs beside Step 1 (`Dispersive::gather_walls`).
        let sweeps = match changes.light_changed() && budget_ms.is_none() {
            true => 8,
            false => 1,
        };
        let small_window = match (changes.moved.is_empty(), doze) {
            (false, _) => Some(WALL_ROWS_WHILE_MOVING),
            (true, true) => Some(WALL_ROWS_DOZING),
            (true, false) => None,
        };
        let gather_early =
            (budget_ms.is_none() && sweeps == 1).then(|| self.wall_window(small_window, None));

        tr("what_changed_and_schedule", frame_start);

        // Step 1 (2.3.2), unless carried to the next frame, with the wall rows a mover passed
        // through; beside them Step 2 (2.3.3) lights the first object the scheduler picked,
        // and finds the light paths of it that a mover crossed (Step 3's amendment).
        let amend_within = self.amend_tolerance(changes);
        let (direct_ms, (first, first_ms, ahead), gathered) = self.direct_beside_first_object(
            world,
            changes,
            (carry, walls_until),
            (&batch, &mut steps, at(0.8), amend_within),
            gather_early,
        );
        steps.direct_ms = direct_ms;

        // Step 2 (2.3.3): the objects the scheduler picked (the first one stored).
        let t = Instant::now();
        let lit = self.light_selected_objects(
            world,
            (batch, FirstObject::Lit(first)),
            &mut stats,
            &mut steps,
            at(0.8),
        );
        steps.objects_ms = first_ms + ms(t);
        tr("step2", t);

        // Step 3 (2.3.4).
        let t = Instant::now();
        let updated = lit.clone();
        stats.energy.object_emitters = self.objects_to_boundary(world, lit, (amend_within, ahead));
        steps.to_boundary_ms = ms(t);
        tr("step3", t);

        // Step 4 (2.3.5): full wall sweeps when the light changed.
        let t = Instant::now();
        let window = self.wall_window(small_window, budget_ms.map(|b| b - ms(frame_start)));
        let change = self.assemble(world, (sweeps, window), gathered);
        self.wall_unswept = change + if doze { self.wall_unswept } else { 0.0 };
        steps.assemble_ms = ms(t);
        tr("step4", t);

        let tt = Instant::now();
        self.meter_and_guard(world, &mut stats);
        self.meter_ms = ms(tt);
        self.tail_ms = steps.assemble_ms + self.meter_ms;
        tr("meter_and_guard", tt);
        let tt = Instant::now();
        self.note_settling(changes, &updated, change, &stats);
        tr("note_settling", tt);
        tr("frame", frame_start);

        stats.frame_ms = ms(frame_start);
        stats.stalest = self.scheduler.stalest(self.frame);
        stats.rays_cast = world.rays_cast() - rays_before;
        steps.objects_asleep = self.scheduler.asleep();
        steps.wall_rows_pending = self.wall_rows.as_ref().map_or(0, |r| r.pending_rows());
        stats.solver = SolverStats::Dispersive(steps);
        self.frame += 1;
        stats
    }

    /// Step 1, unless `carry` (carried to the next frame), and the light meter's rays a
    /// mover may have changed ([`IncidentMeter::update`]); beside them Step 2's first object
    /// of `batch` prepared and lit until `deadline`, not yet stored
    /// ([`Dispersive::light_first_object`]: what it reads of Step 1, the direct light of
    /// its patches, is read when it is stored); and the wall rows a mover passed through,
    /// until `walls_until` ([`WallRows::refresh`]), on the side expected to end first: beside
    /// Step 1 when the first object is expected to cost more than Step 1 did at its last
    /// mover (a small box dragged), else after the first object, followed there by Step 4's
    /// gather of `gather`'s window ([`Dispersive::gather_walls`]; the 77k room's largest
    /// object). They share nothing, so each one's short serial stretches leave the others'
    /// work to the second core (the 77k room's moving frame 6.47 -> 5.53 ms on two with
    /// Step 1 beside the wall rows and the meter, 5.41 -> 4.78 with Step 2's first object
    /// beside them too, 4.80 -> 4.66 with the gather).
    /// Once the first object is lit, its light paths a mover crossed are found there too,
    /// for Step 3 to amend its contribution with (`amend_within`: [`CrossedAhead`]).
    /// Returns the time all of it took, the first object's light with the time its Step 2
    /// took (ms; the two overlap) and its crossed paths, and the gather.
    fn direct_beside_first_object(
        &mut self,
        world: &World,
        changes: &Changes,
        (carry, walls_until): (bool, Option<Instant>),
        (batch, steps, deadline, amend_within): (
            &Batch,
            &mut DispersiveStats,
            Option<Instant>,
            f64,
        ),
        gather: Option<Option<usize>>,
    ) -> (f64, FirstLit, Option<WallGather>) {
        // What each side is expected to cost: Step 1 at its last run with a mover, the first
        // object at its last update.
        let direct_expected = match carry || self.direct_sync.moved.is_empty() {
            true => 0.0,
            false => self.direct_sync.cost_ms,
        };
        let object_expected = (batch.0.first()).map_or(0.0, |&k| self.scheduler.expected_cost(k));
        let walls_beside_direct = object_expected > direct_expected;
        let mut step1 = self.take_step1();
        step1.direct_sync.carried = carry;
        let mut meter = std::mem::take(&mut self.light_meter);
        let mut rows = walls_beside_direct.then(|| self.wall_rows.take()).flatten();
        let options = self.options;
        let places = (self.object_boxes.clone(), self.object_spheres.clone());
        let boxes = &places.0[..];
        let lit: Vec<u32> = (batch.0.iter())
            .map(|&k| self.objects[k].object as u32)
            .collect();
        // The wall rows read nothing else of the solver (Step 2 reads the boundary's list
        // too: it prepares Step 3's gather).
        let boundary = self.boundary_patches.clone();
        #[cfg(test)]
        let fail = std::mem::take(&mut self.fail_inside_join);
        let direct_and_meter = || {
            rayon::join(
                || {
                    #[cfg(test)]
                    assert!(!fail, "a fault injected inside the frame's join");
                    let t = Instant::now();
                    if !carry {
                        let moving = !step1.direct_sync.moved.is_empty();
                        let places = (&places.0[..], &places.1[..]);
                        step1.direct_to_boundary(world, (changes, &lit), (&options, places));
                        if moving {
                            step1.direct_sync.cost_ms = ms(t);
                        }
                    }
                    tr("direct_to_boundary", t);
                },
                || {
                    refresh_wall_rows(
                        rows.as_mut(),
                        world,
                        (&boundary, boxes),
                        changes,
                        walls_until,
                    );
                    let tt = Instant::now();
                    meter.update(world, &changes.moved, boxes);
                    tr("light_meter", tt);
                },
            )
        };
        let the_rest = || {
            let t = Instant::now();
            let tt = Instant::now();
            self.forget_stale_caches(world, &batch.0);
            tr("forget_stale", tt);
            let first = self.light_first_object(world, batch, steps, deadline);
            let first_ms = ms(t);
            let tt = Instant::now();
            let ahead = (batch.0.first())
                .filter(|_| first.is_some())
                .and_then(|&k| self.crossed_ahead(world, k, amend_within));
            tr("crossed_ahead", tt);
            if walls_beside_direct {
                return ((first, first_ms, ahead), None);
            }
            let boundary = (&self.boundary_patches[..], &self.object_boxes[..]);
            refresh_wall_rows(
                self.wall_rows.as_mut(),
                world,
                boundary,
                changes,
                walls_until,
            );
            let tt = Instant::now();
            let gathered = gather.map(|window| self.gather_walls(world, 1, window));
            tr("gather_walls", tt);
            ((first, first_ms, ahead), gathered)
        };
        let started = Instant::now();
        let (_, (first, gathered)) = rayon::join(direct_and_meter, the_rest);
        let direct_ms = ms(started);
        if walls_beside_direct {
            self.wall_rows = rows;
        }
        self.light_meter = meter;
        self.put_step1(step1);
        (direct_ms, first, gathered)
    }

    /// The most wall rows Step 4 gathers this frame (`None`: [`WALL_ROWS_PER_FRAME`]): under
    /// a budget what fits the `left` ms, from the measured cost of a row (and the meter's
    /// share), at least a few; at most `small` while something moves
    /// ([`WALL_ROWS_WHILE_MOVING`]) or the walls doze ([`WALL_ROWS_DOZING`]): the walls'
    /// second bounce lags a few frames behind the mover, and the full window returns as soon
    /// as it rests.
    fn wall_window(&self, small: Option<usize>, left: Option<f64>) -> Option<usize> {
        let window = left.map(|left| {
            let left = (left - self.meter_ms).max(0.0);
            ((left / self.row_ms.max(1e-6)) as usize).max(1024)
        });
        match small {
            None => window,
            Some(small) => Some(window.map_or(small, |w| w.min(small))),
        }
    }

    /// The objects this frame updates, and whether they go over what the budget leaves them
    /// (then Step 1, if it may, is carried to the next frame).
    /// Under a budget the objects take what fits after Step 1's expected cost (its last
    /// run with a mover), Step 4's and the meter's (`tail_ms`) and the wall rows' fifth. What
    /// must go although it does not fit (the object the last frame owed, or one over the
    /// staleness bound) takes Step 1's turn, which then waits a frame (never two); when
    /// Step 1 cannot wait, the over-stale wait a frame instead (owed to the next).
    /// `may_carry`: whether Step 1 may wait this frame ([`Dispersive::may_carry_direct`]).
    fn schedule_within(&mut self, budget_ms: Option<f64>, may_carry: bool) -> (Batch, bool) {
        let Some(b) = budget_ms else {
            let batch = self.scheduler.schedule(self.frame, None, Must::OverStale);
            return (batch, false);
        };
        let direct_due = !self.direct_sync.moved.is_empty();
        let direct_ms = if direct_due {
            self.direct_sync.cost_ms
        } else {
            0.0
        };
        let objects_ms = 0.8 * b - direct_ms - self.tail_ms;
        let must = match (self.objects_owed, direct_due && !may_carry) {
            (true, _) => Must::First,
            (false, true) => Must::Nothing,
            (false, false) => Must::OverStale,
        };
        let batch = self.scheduler.schedule(self.frame, Some(objects_ms), must);
        let over = !batch.0.is_empty() && self.scheduler.cost_of(&batch.0) > objects_ms;
        self.objects_owed = batch.0.is_empty() && self.scheduler.asleep() < self.objects.len();
        (batch, over)
    }

    /// Run frames on a static world until every object was updated `passes` times.
    pub fn converge(&mut self, world: &World, passes: usize) -> Vec<FrameStats> {
        let frames = passes * self.objects.len().max(1);
        let mut changes = Changes::default();
        (0..frames)
            .map(|_| {
                let s = self.step(world, &changes);
                changes = Changes::default();
                s
            })
            .collect()
    }
}

/// The first object of a frame, lit beside Step 1: its light (`None`: not ready), the time
/// its Step 2 took (ms) and its crossed light paths found ahead of Step 3.
type FirstLit = (Option<ObjectLight>, f64, Option<CrossedAhead>);

/// With `SHRAD_TRACE` set, print the time since `t` of a part of the frame to stderr
/// ([`crate::trace_part`]).
pub(super) fn tr(label: &str, t: Instant) {
    crate::trace_part(label, t);
}

/// `ms` milliseconds as a duration (0 if negative).
fn secs(ms: f64) -> std::time::Duration {
    std::time::Duration::from_secs_f64(ms.max(0.0) * 1e-3)
}

/// Milliseconds since `t`.
fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// [`WallRows::refresh`] of `rows` (if the wall exchange is on), traced as a part of the frame.
fn refresh_wall_rows(
    rows: Option<&mut WallRows>,
    world: &World,
    (boundary, object_boxes): (&[u32], &[shrad_scene::Aabb]),
    changes: &Changes,
    until: Option<Instant>,
) {
    let t = Instant::now();
    if let Some(rows) = rows {
        rows.refresh(world, (boundary, object_boxes), changes, until);
    }
    tr("refresh_wall_rows", t);
}
