//! The live engine: one value that owns the patched world and one solver, and that every
//! front end drives — the CLI's `render`, `animate` and `bench`, a viewer, Python. At any
//! moment a caller can move an object (any affine map), change a light, go to a time on the
//! scene's animation, switch the solver, step one frame, read the radiosity, render a picture
//! and measure the error against a reference solve of the current state.
//!
//! The engine tracks what changed between frames itself (which objects moved, which lights
//! changed), so no caller builds [`Changes`]: the dispersive solver's scheduler learns from
//! them which objects to update first (paper 2.1, "对于移动较频繁的物体加大计算和绘制的频率").
//!
//! ```no_run
//! use shrad::engine::Engine;
//! use shrad::solver::SolverChoice;
//! let scene = shrad::scene::cornell_box();
//! let mut engine = Engine::new(
//!     scene,
//!     shrad::PatchSizing::Count(8000),
//!     shrad::vis::Backend::Auto,
//!     SolverChoice::Dispersive(Default::default()),
//! )
//! .unwrap();
//! let o = engine.object("short_block").unwrap();
//! let at = engine.transform(o) * glam::Affine3A::from_translation(glam::Vec3::X * 10.0);
//! engine.set_transform(o, at).unwrap();
//! let stats = engine.step();
//! println!("{:.2} ms, error {:.2} %", stats.frame_ms, 100.0 * engine.error().overall);
//! ```

use std::time::Instant;

use glam::{Affine3A, Vec3};
use shrad_scene::{Camera, Role, Scene};
use shrad_vis::Backend;

use crate::frame::{Changes, FrameStats};
use crate::metrics::{relative_error, RelativeError};
use crate::progress::{uninterrupted, Unstoppable};
use crate::reference::{solve, try_solve, ReferenceOptions};
use crate::render::{Image, RenderOptions};
use crate::solver::{Solver, SolverChoice};
use crate::{Error, NoProgress, PatchSizing, Progress, World};

/// A frame that changes the radiosity by less than this (relative, L1) ends
/// [`Engine::converge`].
pub const SETTLED: f64 = 1e-4;
/// Most frames [`Engine::converge`] adds for the light to settle.
pub const MAX_SETTLING_FRAMES: usize = 256;

/// What switching the solver cost: its precomputation ran again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rebuilt {
    /// Milliseconds spent precomputing the new solver.
    pub precompute_ms: f64,
}

/// The patched world, one solver and the changes not yet seen by a frame. `Send`: a server
/// can run it on a thread of its own.
pub struct Engine {
    world: World,
    pub(crate) solver: Solver,
    choice: SolverChoice,
    pending: Changes,
    reference_options: ReferenceOptions,
    frames: u64,
}

impl Engine {
    /// Patch `scene`, build its visibility and precompute `choice`.
    pub fn new(
        scene: Scene,
        sizing: PatchSizing,
        backend: Backend,
        choice: SolverChoice,
    ) -> Result<Engine, Error> {
        Engine::new_with_progress(scene, sizing, backend, choice, &NoProgress)
    }

    /// [`Engine::new`], reporting the solver's set-up to `progress` and stopping with
    /// [`Error::Interrupted`] (no engine) when it asks to ([`Engine::from_world_with_progress`]).
    pub fn new_with_progress(
        scene: Scene,
        sizing: PatchSizing,
        backend: Backend,
        choice: SolverChoice,
        progress: &dyn Progress,
    ) -> Result<Engine, Error> {
        choice.validate()?;
        crate::progress::check(progress)?;
        let world = World::new(scene, sizing, backend)?;
        Engine::from_world_with_progress(world, choice, progress)
    }

    /// An engine over an already patched world; `choice` is validated first.
    pub fn from_world(world: World, choice: SolverChoice) -> Result<Engine, Error> {
        Engine::from_world_with_progress(world, choice, &NoProgress)
    }

    /// [`Engine::from_world`], reporting the solver's set-up to `progress` (a large scene's
    /// takes seconds); [`Error::Interrupted`] when it asks to stop
    /// ([`Solver::new_with_progress`]).
    pub fn from_world_with_progress(
        world: World,
        choice: SolverChoice,
        progress: &dyn Progress,
    ) -> Result<Engine, Error> {
        let solver = Solver::new_with_progress(&world, choice, progress)?;
        Ok(Engine {
            world,
            solver,
            choice,
            pending: Changes::default(),
            reference_options: ReferenceOptions::fast(),
            frames: 0,
        })
    }

    /// The world as it is now (scene, patches, visibility, materials).
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world back, with every change made through the engine.
    pub fn into_world(self) -> World {
        self.world
    }

    /// The solver's settings.
    pub fn solver_choice(&self) -> SolverChoice {
        self.choice
    }

    /// Frames stepped since the engine (or its solver) was made.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The object called `name`, or with index `name` ("3"); an error lists the names.
    pub fn object(&self, name: &str) -> Result<usize, Error> {
        let objects = &self.world.scene.objects;
        if let Some(o) = objects.iter().position(|o| o.name == name) {
            return Ok(o);
        }
        if let Ok(o) = name.parse::<usize>() {
            if o < objects.len() {
                return Ok(o);
            }
        }
        let names: Vec<&str> = objects.iter().map(|o| o.name.as_str()).collect();
        Err(Error::Invalid(format!(
            "no object '{name}' in {} (objects: {})",
            self.world.scene.source,
            names.join(", ")
        )))
    }

    /// Object `o`'s current world transform.
    pub fn transform(&self, o: usize) -> Affine3A {
        self.world.patches.world_from_local[o]
            * Affine3A::from_mat3(self.world.patches.local_from_object[o])
    }

    /// Put object `o` at `world_from_object` (any affine map). Objects near it and the
    /// object itself are updated first by the dispersive scheduler.
    pub fn set_transform(&mut self, o: usize, world_from_object: Affine3A) -> Result<(), Error> {
        if self.world.move_object(o, world_from_object)? && !self.pending.moved.contains(&o) {
            self.pending.moved.push(o);
        }
        Ok(())
    }

    /// Set object `o`'s emitted radiance `L_e` (linear RGB; zero switches it off).
    pub fn set_emission(&mut self, o: usize, emitted_radiance: Vec3) -> Result<(), Error> {
        if self.world.set_emission(o, emitted_radiance)? && !self.pending.relit.contains(&o) {
            self.pending.relit.push(o);
        }
        Ok(())
    }

    /// Set object `o`'s reflectance factor (linear RGB, each in [0, 1]; its base-colour
    /// texture and vertex colours multiply it): a wall painted another colour. Every
    /// solver sees it as a surface whose light changed. A light surface painted from black
    /// (or to black) begins (or ceases) to reflect, which the dispersive solver's set-up
    /// decides: it runs again at the next frame, and the light starts from the lights'
    /// emission (as after [`Engine::set_solver`]).
    pub fn set_reflectance(&mut self, o: usize, reflectance: Vec3) -> Result<(), Error> {
        if self.world.set_reflectance(o, reflectance)? && !self.pending.relit.contains(&o) {
            self.pending.relit.push(o);
        }
        Ok(())
    }

    /// The punctual light called `name`, or with index `name` ("0"); an error lists the names.
    pub fn light(&self, name: &str) -> Result<usize, Error> {
        let lights = &self.world.scene.lights;
        if let Some(l) = lights.iter().position(|l| l.name == name) {
            return Ok(l);
        }
        match name.parse::<usize>() {
            Ok(l) if l < lights.len() => Ok(l),
            _ => Err(Error::Invalid(format!(
                "no light '{name}' in {} (lights: {})",
                self.world.scene.source,
                lights
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ))),
        }
    }

    /// Put punctual light `l` at `world_from_light` (it shines along that frame's -Z) with
    /// linear RGB `color` and photometric `intensity` (candela; lux for a directional
    /// light: [`shrad_scene::Light`]). The next frame re-traces only that light's own shadow
    /// rays when it moved, and none when only its colour or intensity changed.
    pub fn set_light(
        &mut self,
        l: usize,
        world_from_light: Affine3A,
        color: Vec3,
        intensity: f32,
    ) -> Result<(), Error> {
        if self
            .world
            .set_light(l, world_from_light, color, intensity)?
            && !self.pending.lights.contains(&l)
        {
            self.pending.lights.push(l);
        }
        Ok(())
    }

    /// Where punctual light `l` is now: its node transform (it shines along that frame's
    /// -Z), as [`Engine::set_light`] last put it, or for an animated light its pose at the
    /// current time. An error names the lights when `l` is out of range.
    pub fn light_transform(&self, l: usize) -> Result<Affine3A, Error> {
        let lights = &self.world.scene.lights;
        let light = lights.get(l).ok_or_else(|| {
            Error::Invalid(format!(
                "no light {l}: the scene has {} (0..{})",
                lights.len(),
                lights.len()
            ))
        })?;
        Ok(light.world_from_light_at(self.world.time))
    }

    /// The time the world is at (seconds on the scene's animation; 0 until
    /// [`Engine::set_time`]).
    pub fn time(&self) -> f32 {
        self.world.time
    }

    /// Put the sky `environment` (`None`: none) in place of the scene's. A changed sky is a
    /// light change: the next frame re-traces the sky's direct light and wakes everything.
    pub fn set_sky(&mut self, environment: Option<shrad_scene::Environment>) -> Result<(), Error> {
        let sky = self.world.lights.len();
        if self.world.set_sky(environment)? && !self.pending.lights.contains(&sky) {
            self.pending.lights.push(sky);
        }
        Ok(())
    }

    /// Go to time `t` (seconds) on the scene's animation: animated objects and lights take
    /// their pose there (overriding `set_transform` / `set_emission` on those objects).
    pub fn set_time(&mut self, t: f32) -> Result<(), Error> {
        if !t.is_finite() {
            return Err(Error::Invalid(format!("time {t} is not a finite number")));
        }
        let before = self.world.lights.clone();
        let (moved, relit) = self.world.set_time(t)?;
        for (l, (a, b)) in before.iter().zip(&self.world.lights).enumerate() {
            if a != b && !self.pending.lights.contains(&l) {
                self.pending.lights.push(l);
            }
        }
        for o in moved {
            if !self.pending.moved.contains(&o) {
                self.pending.moved.push(o);
            }
        }
        for o in relit {
            if !self.pending.relit.contains(&o) {
                self.pending.relit.push(o);
            }
        }
        Ok(())
    }

    /// Switch the solver or change its settings. Its precomputation runs again (probe
    /// boxes, transfer vectors, wall form factors...), and the state starts from the lights'
    /// emission; the result says what that cost. Invalid settings are an error, and the
    /// solver in use stays.
    pub fn set_solver(&mut self, choice: SolverChoice) -> Result<Rebuilt, Error> {
        let t = Instant::now();
        self.solver = Solver::new(&self.world, choice)?;
        self.choice = choice;
        self.frames = 0;
        self.pending = Changes::default();
        Ok(Rebuilt {
            precompute_ms: t.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Put in `solver`, precomputed for `choice` by [`Solver::new`] on another world with
    /// this one's patches (a viewer keeps such a copy so that a precomputation runs beside
    /// the frames instead of stopping them). `changed_since`: the objects moved and the
    /// lights changed between that world's state and this one's; the first frame takes them
    /// in as ordinary changes. An error (and the solver in use stays) when the patch counts
    /// differ.
    pub fn install_solver(
        &mut self,
        solver: Solver,
        choice: SolverChoice,
        changed_since: Changes,
    ) -> Result<(), Error> {
        if solver.radiosity().len() != self.world.patches.len() {
            return Err(Error::Invalid(format!(
                "a solver of {} patches cannot run on a world of {}",
                solver.radiosity().len(),
                self.world.patches.len()
            )));
        }
        self.solver = solver;
        self.choice = choice;
        self.frames = 0;
        self.pending = changed_since;
        Ok(())
    }

    /// Change one setting of the solver in use by name (`set_option("cube_res", "64")`; keys
    /// in [`crate::settings`], listed by [`SolverChoice::keys`]). A key whose
    /// [`rebuilds`](crate::settings::KeySpec::rebuilds) is set runs the precomputation again
    /// and returns what that cost; the others (the dispersive schedule, every reference
    /// setting) apply from the next frame and return `None`. A bad key or value is an error
    /// and changes nothing.
    pub fn set_option(&mut self, key: &str, value: &str) -> Result<Option<Rebuilt>, Error> {
        let mut next = self.choice;
        let spec = next.set(key, value)?;
        if spec.rebuilds {
            return self.set_solver(next).map(Some);
        }
        match (&mut self.solver, next) {
            (Solver::Dispersive(d), SolverChoice::Dispersive(o)) => d.set_schedule(o.schedule)?,
            (Solver::Reference { options, .. }, SolverChoice::Reference(n)) => *options = n,
            _ => return self.set_solver(next).map(Some),
        }
        self.choice = next;
        Ok(None)
    }

    /// The value of setting `key` of the solver in use, as text.
    pub fn option(&self, key: &str) -> Result<String, Error> {
        self.choice.get(key)
    }

    /// Change the dispersive solver's schedule live (no precomputation); an error for the
    /// other solvers, which have none.
    pub fn set_schedule(&mut self, schedule: crate::dispersive::Schedule) -> Result<(), Error> {
        match &mut self.solver {
            Solver::Dispersive(d) => {
                d.set_schedule(schedule)?;
                self.choice = SolverChoice::Dispersive(*d.options());
                Ok(())
            }
            _ => Err(Error::Invalid(
                "only the dispersive solver has a schedule".to_string(),
            )),
        }
    }

    /// One frame that updates as many objects as fit in `budget_ms` (by priority, at least
    /// one; paper 2.1's time slicing). The grid and the reference have no such choice: they
    /// step a whole frame.
    pub fn step_within(&mut self, budget_ms: f32) -> Result<FrameStats, Error> {
        use crate::dispersive::Schedule;
        let Solver::Dispersive(d) = &mut self.solver else {
            return Ok(self.step());
        };
        let before = d.schedule();
        let max_staleness = match before {
            Schedule::Priority { max_staleness, .. } | Schedule::Budget { max_staleness, .. } => {
                max_staleness
            }
            _ => 16,
        };
        d.set_schedule(Schedule::Budget {
            ms: budget_ms,
            max_staleness,
        })?;
        let stats = self.step();
        if let Solver::Dispersive(d) = &mut self.solver {
            d.set_schedule(before)?;
        }
        Ok(stats)
    }

    /// Settings of the reference that [`Engine::error`] solves (fast by default).
    pub fn set_reference_options(&mut self, options: ReferenceOptions) {
        self.reference_options = options;
    }

    /// The settings of the reference that [`Engine::error`] solves.
    pub fn reference_options(&self) -> &ReferenceOptions {
        &self.reference_options
    }

    /// One frame, with the changes since the last one.
    pub fn step(&mut self) -> FrameStats {
        self.step_with_progress(&NoProgress)
    }

    /// [`Engine::step`], reporting the progress of a long frame to `progress`: the
    /// reference's form factors and iterations. A dispersive or grid frame (milliseconds)
    /// reports nothing; a caller running many of them counts frames itself. It never stops
    /// the frame ([`Engine::try_step_with_progress`] does).
    pub fn step_with_progress(&mut self, progress: &dyn Progress) -> FrameStats {
        uninterrupted(self.try_step_with_progress(&Unstoppable(progress)))
    }

    /// [`Engine::step_with_progress`], or [`Error::Interrupted`] when `progress` asks to
    /// stop (before the frame, or within a reference frame): the engine is then as it was,
    /// its changes still pending for the next frame.
    pub fn try_step_with_progress(&mut self, progress: &dyn Progress) -> Result<FrameStats, Error> {
        let changes = std::mem::take(&mut self.pending);
        let (world, solver) = (&self.world, &mut self.solver);
        let step = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            solver.try_step_with_progress(world, &changes, progress)
        }));
        let step = step.unwrap_or_else(|panic| {
            // A panic inside a frame (a bug) may leave the solver's state half lent out (the
            // dispersive frame hands Step 1's caches to a thread of its join): the solver is
            // built again for the world as it stands, so that a front end that catches the
            // panic (Python, the viewer's engine thread) goes on with a whole engine; then
            // the panic goes on to it.
            if let Ok(fresh) = Solver::new(&self.world, self.choice) {
                self.solver = fresh;
            }
            std::panic::resume_unwind(panic)
        });
        match step {
            Ok(stats) => {
                self.frames += 1;
                Ok(stats)
            }
            Err(e) => {
                self.pending = changes;
                Err(e)
            }
        }
    }

    /// Frames a static scene needs to converge: every object updated `passes` times.
    pub fn frames_to_converge(&self, passes: usize) -> usize {
        self.solver.frames_to_converge(passes)
    }

    /// Run the frames a static scene needs to converge: every object updated `passes` times,
    /// and then, for the dispersive solver and the grid, frames until the light settles.
    pub fn converge(&mut self, passes: usize) -> Vec<FrameStats> {
        self.converge_with_progress(passes, &NoProgress)
    }

    /// [`Engine::converge`], each frame stepped with [`Engine::step_with_progress`].
    ///
    /// The dispersive solver's wall exchange takes one Jacobi sweep a frame, so in a scene
    /// with few objects the light between the walls is far from settled when every object
    /// has been updated twice: the Cornell box (two objects, four frames) was 5-7 % darker
    /// than converged (every wall; the short block 10 %). Frames follow until one changes
    /// the radiosity by less than [`SETTLED`] (relative, L1), at most [`MAX_SETTLING_FRAMES`].
    pub fn converge_with_progress(
        &mut self,
        passes: usize,
        progress: &dyn Progress,
    ) -> Vec<FrameStats> {
        let step =
            |e: &mut Engine| Ok::<_, std::convert::Infallible>(e.step_with_progress(progress));
        match self.converge_by(passes, step) {
            Ok(stats) => stats,
            Err(never) => match never {},
        }
    }

    /// [`Engine::converge`] with each frame stepped by `step`, whose error ends the run
    /// there (a front end's interruption: Python's Ctrl-C is seen between frames, on the
    /// calling thread). The frames a front end needs no copy of: [`Engine::frames_to_converge`],
    /// then for the dispersive solver and the grid up to [`MAX_SETTLING_FRAMES`] until one changes the
    /// radiosity by at most [`SETTLED`] (relative, L1). The statistics grow a frame at a
    /// time (a count of frames far beyond what can be stepped allocates nothing up front).
    pub fn converge_by<E>(
        &mut self,
        passes: usize,
        mut step: impl FnMut(&mut Engine) -> Result<FrameStats, E>,
    ) -> Result<Vec<FrameStats>, E> {
        let mut stats = Vec::new();
        for _ in 0..self.solver.frames_to_converge(passes) {
            stats.push(step(self)?);
        }
        stats.extend(self.settle_by(step)?);
        Ok(stats)
    }

    /// Frames stepped by `step` until one changes the radiosity by at most [`SETTLED`]
    /// (relative, L1), at most [`MAX_SETTLING_FRAMES`]; none for the reference, which
    /// solves to convergence in its one frame. The grid, too, gathers one bounce a frame:
    /// after [`Engine::frames_to_converge`] a closed box of reflectance 0.5 had 1.75 of its
    /// converged 2.0 (-12.5 %).
    pub fn settle_by<E>(
        &mut self,
        mut step: impl FnMut(&mut Engine) -> Result<FrameStats, E>,
    ) -> Result<Vec<FrameStats>, E> {
        let mut stats = Vec::new();
        if matches!(self.solver, Solver::Reference { .. }) {
            return Ok(stats);
        }
        let mut previous = self.radiosity().to_vec();
        for _ in 0..MAX_SETTLING_FRAMES {
            stats.push(step(self)?);
            let now = self.radiosity();
            let (change, total) = now
                .iter()
                .zip(&previous)
                .fold((0f64, 0f64), |(c, t), (a, b)| {
                    (
                        c + (*a - *b).abs().element_sum() as f64,
                        t + a.element_sum() as f64,
                    )
                });
            if change <= SETTLED * total {
                break;
            }
            previous.copy_from_slice(now);
        }
        Ok(stats)
    }

    /// The radiosity `B` of every patch (linear RGB, W/m^2).
    pub fn radiosity(&self) -> &[Vec3] {
        self.solver.radiosity()
    }

    /// Radiosity at every shading vertex (the colours a viewer draws), area-weighted.
    pub fn vertex_colors(&self) -> Vec<Vec3> {
        crate::render::vertex_radiosity(&self.world, self.solver.radiosity())
    }

    /// The role of every object.
    pub fn roles(&self) -> &[Role] {
        &self.world.patches.object_role
    }

    /// A linear picture from `camera` (when `None`, the scene's camera at the current time,
    /// which follows its animated glTF node, or one that frames the scene).
    pub fn render(&self, camera: Option<&Camera>, options: &RenderOptions) -> Result<Image, Error> {
        crate::limits::check_image(options.width, options.height, options.spp)?;
        let own = self.world.scene.camera_or_default_at(self.world.time);
        Ok(crate::render::render_with_punctual(
            &self.world,
            self.solver.radiosity(),
            self.solver.punctual_irradiance(),
            camera.unwrap_or(&own),
            options,
        ))
    }

    /// The error of the current state against a reference solve of the same state (spec 8).
    pub fn error(&self) -> RelativeError {
        let (reference, _) = solve(&self.world, &self.reference_options, &NoProgress);
        relative_error(&self.world.patches, self.solver.radiosity(), &reference)
    }

    /// [`Engine::error`], reporting the reference solve to `progress`, or
    /// [`Error::Interrupted`] when it asks to stop ([`crate::reference::try_solve`]).
    pub fn error_with_progress(&self, progress: &dyn Progress) -> Result<RelativeError, Error> {
        self.error_against(&self.reference_options, progress)
    }

    /// [`Engine::error_with_progress`] against a reference solved with `options` rather than
    /// the engine's own ([`Engine::reference_options`]).
    pub fn error_against(
        &self,
        options: &ReferenceOptions,
        progress: &dyn Progress,
    ) -> Result<RelativeError, Error> {
        let (reference, _) = try_solve(&self.world, options, progress)?;
        Ok(relative_error(
            &self.world.patches,
            self.solver.radiosity(),
            &reference,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_send<T: Send>() {}

    /// A panic inside a frame's join (a bug) reaches the caller, and the engine that caught
    /// it is whole: its next frames are those of an engine built where it stands. Before,
    /// Step 1's state stayed lent out and every later frame failed.
    #[test]
    fn a_frame_that_panics_leaves_the_engine_whole() {
        let choice = SolverChoice::Dispersive(crate::dispersive::DispersiveOptions::improved());
        let build = || {
            let scene = shrad_scene::cornell_box();
            Engine::new(scene, PatchSizing::Count(1500), Backend::Auto, choice).unwrap()
        };
        let (mut engine, mut fresh) = (build(), build());
        engine.step();
        let Solver::Dispersive(d) = &mut engine.solver else {
            panic!("not the dispersive solver");
        };
        d.fail_inside_join = true;
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| engine.step()));
        let message = caught.expect_err("the frame did not panic");
        let message = message.downcast_ref::<&str>().copied().unwrap_or_default();
        assert!(message.contains("fault injected"), "{message}");
        for _ in 0..3 {
            let (a, b) = (engine.step(), fresh.step());
            assert!(a.diverged.is_none(), "{:?}", a.diverged);
            assert_eq!(a.rays_cast, b.rays_cast);
        }
        let error = relative_error(&engine.world.patches, engine.radiosity(), fresh.radiosity());
        assert!(error.overall < 1e-4, "{error:?}");
    }

    /// Counts every call, as a progress bar would draw them.
    #[derive(Default)]
    struct Counting {
        begun: std::sync::atomic::AtomicU64,
        advanced: std::sync::atomic::AtomicU64,
        ended: std::sync::atomic::AtomicU64,
    }

    impl Progress for Counting {
        fn begin(&self, _: &str, _: u64) {
            self.begun
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        fn advance(&self, n: u64) {
            self.advanced
                .fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
        fn end(&self) {
            self.ended
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    }

    /// Asks to stop once `after` units of work are done (Python's Ctrl-C sets such a flag
    /// from outside); counts the steps begun and ended.
    struct StopAfter {
        after: u64,
        done: std::sync::atomic::AtomicU64,
        open: std::sync::atomic::AtomicI64,
    }

    impl StopAfter {
        fn new(after: u64) -> StopAfter {
            StopAfter {
                after,
                done: Default::default(),
                open: Default::default(),
            }
        }
    }

    impl Progress for StopAfter {
        fn begin(&self, _: &str, _: u64) {
            self.open.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        fn advance(&self, n: u64) {
            self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
        }
        fn end(&self) {
            self.open.fetch_sub(1, std::sync::atomic::Ordering::Relaxed);
        }
        fn stop_requested(&self) -> bool {
            self.done.load(std::sync::atomic::Ordering::Relaxed) >= self.after
        }
    }

    fn cornell(solver: &str, preset: &str) -> Engine {
        Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(300),
            Backend::Auto,
            SolverChoice::preset(solver, preset).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn a_progress_that_asks_to_stop_ends_the_long_work_interrupted() {
        use std::sync::atomic::Ordering::Relaxed;
        fn interrupted<T>(r: Result<T, Error>) -> bool {
            matches!(r, Err(Error::Interrupted))
        }
        // Setting up the dispersive solver: stopped after its first object (the Cornell box
        // has two), or before any work.
        for after in [0, 1] {
            let stop = StopAfter::new(after);
            let built = Engine::new_with_progress(
                shrad_scene::cornell_box(),
                PatchSizing::Count(300),
                Backend::Auto,
                SolverChoice::preset("dispersive", "default").unwrap(),
                &stop,
            );
            assert!(interrupted(built), "after {after}");
            assert_eq!(stop.done.load(Relaxed), after);
            assert_eq!(stop.open.load(Relaxed), 0, "every step begun is ended");
        }
        // `error()`'s reference solve: stopped after the direct light, before the form
        // factors; the engine is whole.
        let mut e = cornell("dispersive", "default");
        e.step();
        let stop = StopAfter::new(1);
        assert!(interrupted(e.error_with_progress(&stop)));
        assert_eq!(stop.done.load(Relaxed), 1);
        assert_eq!(stop.open.load(Relaxed), 0);
        assert!(e
            .error_with_progress(&NoProgress)
            .unwrap()
            .overall
            .is_finite());
        // A reference frame: stopped within its solve (after the direct light and the form
        // factors); the frame is not counted and the radiosity is as it was.
        let mut e = cornell("reference", "fast");
        let before = e.radiosity().to_vec();
        let stop = StopAfter::new(2);
        assert!(interrupted(e.try_step_with_progress(&stop)));
        assert_eq!(stop.open.load(Relaxed), 0);
        assert_eq!((e.frames(), e.radiosity()), (0, &before[..]));
        // The infallible forms never stop.
        assert_eq!(e.step_with_progress(&StopAfter::new(0)).frame, 0);
        assert_eq!(e.frames(), 1);
    }

    #[test]
    fn a_reference_step_reports_its_progress() {
        use std::sync::atomic::Ordering::Relaxed;
        let mut e = Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(300),
            Backend::Auto,
            SolverChoice::preset("reference", "fast").unwrap(),
        )
        .unwrap();
        let counting = Counting::default();
        let s = e.step_with_progress(&counting);
        assert!(s.reference().is_some_and(|r| r.iterations > 0), "{s:?}");
        // Direct light, form factors and iterations: each begun and ended, with work done.
        let begun = counting.begun.load(Relaxed);
        assert!(begun >= 3, "{begun} steps begun");
        assert_eq!(counting.ended.load(Relaxed), begun);
        assert!(counting.advanced.load(Relaxed) > 0);
        assert_eq!(e.frames(), 1);
        // The converging loop passes it on too.
        let before = counting.advanced.load(Relaxed);
        assert_eq!(e.converge_with_progress(1, &counting).len(), 1);
        assert!(counting.advanced.load(Relaxed) > before);
    }

    /// The short block's radiosity in `e` against `want`: the largest difference of a patch
    /// over the block's brightest patch.
    fn block_difference(e: &Engine, want: &[Vec3]) -> f32 {
        let o = e.object("short_block").unwrap();
        let r = e.world().patches.range(o);
        let b = &e.radiosity()[r.clone()];
        let max = want[r.clone()]
            .iter()
            .map(|y| y.max_element())
            .fold(0.0, f32::max);
        let d = b
            .iter()
            .zip(&want[r])
            .map(|(x, y)| (*x - *y).abs().max_element());
        d.fold(0.0, f32::max) / max
    }

    #[test]
    fn a_solver_precomputed_on_a_copy_at_rest_lights_the_moved_scene_as_a_fresh_one() {
        let choice = SolverChoice::Dispersive(Default::default());
        let world = || {
            World::new(
                shrad_scene::cornell_box(),
                PatchSizing::Count(400),
                Backend::Auto,
            )
        };
        let mut e = Engine::from_world(world().unwrap(), choice).unwrap();
        // Precomputed on a copy at rest while the engine's block moves.
        let solver = Solver::new(&world().unwrap(), choice).unwrap();
        let o = e.object("short_block").unwrap();
        let at = Affine3A::from_translation(Vec3::new(0.25, 0.0, 0.15)) * e.transform(o);
        e.set_transform(o, at).unwrap();
        let since = Changes {
            moved: vec![o],
            ..Default::default()
        };
        e.install_solver(solver, choice, since).unwrap();
        assert_eq!(e.frames(), 0);
        e.converge(2);
        // As a solver precomputed on the moved world. (A new solver's caches are empty, so
        // its first updates trace the world as it is; `since` tells its scheduler which
        // objects to take first: without it this would pass too.)
        let mut fresh = Engine::from_world(world().unwrap(), choice).unwrap();
        fresh.set_transform(o, at).unwrap();
        fresh.converge(2);
        let d = block_difference(&e, fresh.radiosity());
        assert!(d < 0.02, "the block's light differs by {:.2} %", 100.0 * d);
        // A solver of another patching is refused; the one in use stays.
        let other = World::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(900),
            Backend::Auto,
        );
        let wrong = Solver::new(&other.unwrap(), choice).unwrap();
        assert!(e.install_solver(wrong, choice, Changes::default()).is_err());
        assert_eq!(e.radiosity().len(), fresh.radiosity().len());
    }

    #[test]
    fn a_light_reports_where_it_is_and_a_moved_one_lights_as_one_loaded_there() {
        use shrad_scene::{Light, LightKind};
        let at = |p: Vec3| Affine3A::from_translation(p);
        let scene = |p: Vec3| {
            let mut s = shrad_scene::cornell_box();
            s.lights.push(Light {
                world_from_light: at(p),
                // (The box is 556 units wide: a bulb about as bright on the floor as the
                // ceiling's light.)
                ..Light::new("bulb", LightKind::Point, 5e8)
            });
            s
        };
        let engine = |p: Vec3| {
            Engine::new(
                scene(p),
                PatchSizing::Count(400),
                Backend::Auto,
                SolverChoice::preset("reference", "fast").unwrap(),
            )
            .unwrap()
        };
        let (a, b) = (
            Vec3::new(150.0, 400.0, 200.0),
            Vec3::new(380.0, 300.0, 350.0),
        );
        let mut e = engine(a);
        assert_eq!(e.light_transform(0).unwrap(), at(a));
        assert_eq!(e.time(), 0.0);
        let (color, intensity) = (Vec3::new(1.0, 0.5, 0.25), 8e8);
        e.set_light(0, at(b), color, intensity).unwrap();
        assert_eq!(e.light_transform(0).unwrap(), at(b));
        let err = e.light_transform(1).unwrap_err().to_string();
        assert!(err.contains("no light 1") && err.contains("has 1"), "{err}");
        e.step();
        let mut fresh = engine(b);
        fresh.set_light(0, at(b), color, intensity).unwrap();
        fresh.step();
        // The reference solves the state from scratch: the same state, the same radiosity.
        assert_eq!(e.radiosity(), fresh.radiosity());
        // ... and not the state it moved from.
        let mut before = engine(a);
        before.step();
        assert_ne!(e.radiosity(), before.radiosity());
    }

    #[test]
    fn converge_lets_the_light_between_the_walls_settle() {
        // The Cornell box has two objects: two passes are four frames, four sweeps of the wall
        // exchange, which left every wall 5-7 % darker than converged.
        let choice = SolverChoice::Dispersive(Default::default());
        let make = || {
            Engine::new(
                shrad_scene::cornell_box(),
                PatchSizing::Count(1000),
                Backend::Auto,
                choice,
            )
            .unwrap()
        };
        let mut e = make();
        let frames = e.converge(2).len();
        assert!(frames > e.frames_to_converge(2), "{frames} frames");
        let mut long = make();
        for _ in 0..400 {
            long.step();
        }
        let total = |b: &[Vec3]| b.iter().map(|x| x.element_sum() as f64).sum::<f64>();
        let (got, want) = (total(e.radiosity()), total(long.radiosity()));
        assert!(
            (got - want).abs() < 0.005 * want,
            "{got} against {want} after 400 frames"
        );
    }

    #[test]
    fn the_engine_is_send() {
        assert_send::<Engine>();
    }

    #[test]
    fn bad_steering_is_an_error_not_a_panic() {
        let mut e = Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(500),
            Backend::Auto,
            SolverChoice::Dispersive(Default::default()),
        )
        .unwrap();
        assert!(e
            .object("nope")
            .unwrap_err()
            .to_string()
            .contains("short_block"));
        assert!(e.set_transform(99, Affine3A::IDENTITY).is_err());
        assert!(e
            .set_transform(0, Affine3A::from_scale(Vec3::ZERO))
            .is_err());
        assert!(e
            .set_transform(0, Affine3A::from_translation(Vec3::splat(f32::NAN)))
            .is_err());
        assert!(e.set_emission(0, Vec3::splat(-1.0)).is_err());
        // Finite, but beyond what a solve holds: far away, and emitting 1e38.
        let far = e.set_transform(0, Affine3A::from_translation(Vec3::splat(1e30)));
        assert!(far.unwrap_err().to_string().contains("1e12"));
        assert!(e.set_emission(0, Vec3::splat(1e38)).is_err());
        assert!(e.set_time(f32::INFINITY).is_err());
        e.step();
        assert!(e.radiosity().iter().all(|b| b.is_finite()));
        use crate::dispersive::Schedule;
        assert!(e
            .set_schedule(Schedule::Budget {
                ms: f32::NAN,
                max_staleness: 4
            })
            .is_err());
    }

    #[test]
    fn schedule_and_budget_change_live() {
        use crate::dispersive::Schedule;
        let mut e = Engine::new(
            shrad_scene::room(&shrad_scene::RoomParams {
                objects: 4,
                patches: 1500,
                big_object_patches: None,
            }),
            PatchSizing::Count(1500),
            Backend::Auto,
            SolverChoice::Dispersive(Default::default()),
        )
        .unwrap();
        assert_eq!(e.step().objects_updated.len(), 1);
        e.set_schedule(Schedule::RoundRobin { per_frame: 3 })
            .unwrap();
        assert_eq!(e.step().objects_updated.len(), 3);
        e.set_schedule(Schedule::Full).unwrap();
        assert_eq!(e.step().objects_updated.len(), 4);
        // A budget of a millionth of a millisecond: the frame carries its object over and the
        // next takes the one it owes, whatever it costs (no object starves); the schedule in
        // force comes back afterwards.
        let owed = e.step_within(1e-6).unwrap().objects_updated.len();
        let paid = e.step_within(1e-6).unwrap().objects_updated.len();
        assert_eq!((owed, paid), (0, 1));
        assert_eq!(e.step().objects_updated.len(), 4);
    }

    #[test]
    fn options_change_by_name_and_rebuild_only_when_needed() {
        let mut e = Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(500),
            Backend::Auto,
            SolverChoice::preset("dispersive", "default").unwrap(),
        )
        .unwrap();
        assert_eq!(e.set_option("per_frame", "2").unwrap(), None);
        assert_eq!(e.option("per_frame").unwrap(), "2");
        assert_eq!(e.step().objects_updated.len(), 2);
        assert!(e.set_option("cube_res", "16").unwrap().is_some());
        assert_eq!(e.frames(), 0, "a rebuild starts the solver again");
        let before = e.solver_choice();
        let err = e.set_option("bands", "9").unwrap_err().to_string();
        assert!(err.contains("bands") && err.contains("1..=8"), "{err}");
        assert_eq!(e.solver_choice(), before);
        // Settings built by hand are checked too: an error, not a panic in shrad-sh.
        let bad = SolverChoice::Dispersive(crate::dispersive::DispersiveOptions {
            bands: 9,
            ..Default::default()
        });
        assert!(e.set_solver(bad).is_err());
        assert_eq!(e.solver_choice(), before);
        e.set_solver(SolverChoice::preset("reference", "fast").unwrap())
            .unwrap();
        assert_eq!(e.set_option("rays_per_patch", "16").unwrap(), None);
        assert_eq!(e.option("rays_per_patch").unwrap(), "16");
        assert!(e.set_option("cube_res", "16").is_err());
    }

    #[test]
    fn every_solver_reports_through_one_frame_interface() {
        use crate::frame::SolverStats;
        let mut e = Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(400),
            Backend::Auto,
            SolverChoice::preset("dispersive", "default").unwrap(),
        )
        .unwrap();
        for (solver, preset) in [
            ("dispersive", "paper"),
            ("grid", "paper4"),
            ("reference", "fast"),
        ] {
            e.set_solver(SolverChoice::preset(solver, preset).unwrap())
                .unwrap();
            let s = e.step();
            assert!(s.rays_cast > 0, "{solver}: {s:?}");
            assert!(
                s.frame_ms > 0.0 && s.energy.emitted > 0.0,
                "{solver}: {s:?}"
            );
            match (&s.solver, solver) {
                (SolverStats::Dispersive(d), "dispersive") => {
                    assert_eq!(s.objects_updated.len(), 1);
                    assert!(d.probes_captured >= 8);
                }
                (SolverStats::Grid(g), "grid") => assert_eq!(g.probes, 64),
                (SolverStats::Reference(r), "reference") => {
                    assert!(r.converged && r.iterations > 0)
                }
                (other, _) => panic!("{solver} reported {other:?}"),
            }
            assert_eq!(e.step().frame, 1, "{solver} counts its frames");
        }
    }
}
