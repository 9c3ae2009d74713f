//! The three solvers behind one frame interface, so that `render`, `animate` and `bench`
//! drive them the same way.

use glam::Vec3;

use crate::dispersive::{Dispersive, DispersiveOptions};
use crate::frame::{Changes, FrameStats};
use crate::grid::{Grid, GridOptions};
use crate::progress::{check, uninterrupted, Unstoppable};
use crate::reference::ReferenceOptions;
use crate::{NoProgress, Progress, World};

/// Which solver, with its settings. By name: [`SolverChoice::preset`], [`SolverChoice::set`]
/// and the key tables of [`crate::settings`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolverChoice {
    /// Converged radiosity every frame (ground truth, slow).
    Reference(ReferenceOptions),
    /// The paper's method.
    Dispersive(DispersiveOptions),
    /// The uniform probe grid baseline.
    Grid(GridOptions),
}

/// A solver's state across frames.
pub enum Solver {
    /// See [`SolverChoice::Reference`].
    Reference {
        /// Its settings.
        options: ReferenceOptions,
        /// The radiosity of the last frame solved (the exitance before the first).
        radiosity: Vec<Vec3>,
        /// Frames solved so far.
        frames: u64,
        /// The punctual lights' direct irradiance of every patch.
        punctual: Vec<Vec3>,
    },
    /// See [`SolverChoice::Dispersive`].
    Dispersive(Box<Dispersive>),
    /// See [`SolverChoice::Grid`].
    Grid(Box<Grid>),
}

impl Solver {
    /// Precompute for `world`; settings out of range are an error
    /// ([`SolverChoice::validate`]).
    pub fn new(world: &World, choice: SolverChoice) -> Result<Solver, crate::Error> {
        Solver::new_with_progress(world, choice, &NoProgress)
    }

    /// [`Solver::new`], reporting the set-up's progress (the dispersive objects' transfer
    /// vectors, the wall rows) to `progress`; [`crate::Error::Interrupted`] when it asks to
    /// stop (no solver is made).
    pub fn new_with_progress(
        world: &World,
        choice: SolverChoice,
        progress: &dyn Progress,
    ) -> Result<Solver, crate::Error> {
        choice.validate()?;
        Ok(match choice {
            SolverChoice::Reference(options) => Solver::Reference {
                options,
                radiosity: world.exitance.clone(),
                frames: 0,
                punctual: Vec::new(),
            },
            SolverChoice::Dispersive(o) => {
                Solver::Dispersive(Box::new(Dispersive::new_with_progress(world, o, progress)?))
            }
            SolverChoice::Grid(o) => Solver::Grid(Box::new(Grid::new(world, o)?)),
        })
    }

    /// One frame at the world's current time.
    pub fn step(&mut self, world: &World, changes: &Changes) -> FrameStats {
        self.step_with_progress(world, changes, &NoProgress)
    }

    /// One frame, reporting the progress of a long one: the reference's form factors and
    /// iterations (a frame of it can take minutes). A dispersive or grid frame takes
    /// milliseconds and reports nothing. Never stops ([`Solver::try_step_with_progress`]
    /// does).
    pub fn step_with_progress(
        &mut self,
        world: &World,
        changes: &Changes,
        progress: &dyn Progress,
    ) -> FrameStats {
        uninterrupted(self.try_step_with_progress(world, changes, &Unstoppable(progress)))
    }

    /// [`Solver::step_with_progress`], or [`crate::Error::Interrupted`] when `progress` asks
    /// to stop: before the frame, and within a reference frame (whose solve is thrown away:
    /// the solver is as it was).
    pub fn try_step_with_progress(
        &mut self,
        world: &World,
        changes: &Changes,
        progress: &dyn Progress,
    ) -> Result<FrameStats, crate::Error> {
        check(progress)?;
        Ok(match self {
            Solver::Reference {
                options,
                radiosity,
                frames,
                punctual,
            } => {
                let (solved, direct, stats) =
                    crate::reference::frame(world, options, *frames, progress)?;
                *radiosity = solved;
                *punctual = direct;
                *frames += 1;
                stats
            }
            Solver::Dispersive(d) => d.step(world, changes),
            Solver::Grid(g) => g.step(world, changes),
        })
    }

    /// Frames a static scene needs to converge (`passes` updates of every object).
    pub fn frames_to_converge(&self, passes: usize) -> usize {
        match self {
            Solver::Reference { .. } => 1,
            Solver::Dispersive(d) => passes.saturating_mul(d.frames_per_pass()),
            Solver::Grid(_) => passes,
        }
    }

    /// Radiosity of every patch.
    pub fn radiosity(&self) -> &[Vec3] {
        match self {
            Solver::Reference { radiosity, .. } => radiosity,
            Solver::Dispersive(d) => d.radiosity(),
            Solver::Grid(g) => g.radiosity(),
        }
    }

    /// The punctual lights' direct irradiance of every patch as the last frame computed it
    /// (footprint averages; empty before the first frame or without punctual lights): the
    /// part of each patch's irradiance a picture evaluates per pixel instead.
    pub fn punctual_irradiance(&self) -> &[Vec3] {
        match self {
            Solver::Reference { punctual, .. } => punctual,
            Solver::Dispersive(d) => d.punctual_irradiance(),
            Solver::Grid(g) => g.punctual_irradiance(),
        }
    }
}
