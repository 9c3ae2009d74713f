//! The three solvers behind one frame interface, so that `render`, `animate` and `bench`
//! drive them the same way.

use std::time::Instant;

use glam::Vec3;

use crate::dispersive::{Changes, Dispersive, DispersiveOptions, FrameStats};
use crate::grid::{Grid, GridOptions};
use crate::reference::{solve, ReferenceOptions};
use crate::{NoProgress, World};

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
    Reference(ReferenceOptions, Vec<Vec3>),
    /// See [`SolverChoice::Dispersive`].
    Dispersive(Box<Dispersive>),
    /// See [`SolverChoice::Grid`].
    Grid(Box<Grid>),
}

impl Solver {
    /// Precompute for `world`; settings out of range are an error
    /// ([`SolverChoice::validate`]).
    pub fn new(world: &World, choice: SolverChoice) -> Result<Solver, crate::Error> {
        choice.validate()?;
        Ok(match choice {
            SolverChoice::Reference(o) => Solver::Reference(o, world.exitance.clone()),
            SolverChoice::Dispersive(o) => Solver::Dispersive(Box::new(Dispersive::new(world, o))),
            SolverChoice::Grid(o) => Solver::Grid(Box::new(Grid::new(world, o))),
        })
    }

    /// One frame at the world's current time.
    pub fn step(&mut self, world: &World, changes: &Changes) -> FrameStats {
        match self {
            Solver::Reference(o, b) => {
                let t = Instant::now();
                let (radiosity, stats) = solve(world, o, &NoProgress);
                *b = radiosity;
                FrameStats {
                    frame_ms: t.elapsed().as_secs_f64() * 1e3,
                    energy: stats.energy,
                    diverged: (stats.non_finite > 0).then(|| crate::energy::Divergence {
                        message: format!("{} non-finite value(s) reset to 0", stats.non_finite),
                        non_finite: stats.non_finite,
                    }),
                    ..Default::default()
                }
            }
            Solver::Dispersive(d) => d.step(world, changes),
            Solver::Grid(g) => g.step(world, changes),
        }
    }

    /// Frames a static scene needs to converge (`passes` updates of every object).
    pub fn frames_to_converge(&self, passes: usize) -> usize {
        match self {
            Solver::Reference(..) => 1,
            Solver::Dispersive(d) => passes * d.frames_per_pass(),
            Solver::Grid(_) => passes,
        }
    }

    /// Radiosity of every patch.
    pub fn radiosity(&self) -> &[Vec3] {
        match self {
            Solver::Reference(_, b) => b,
            Solver::Dispersive(d) => d.radiosity(),
            Solver::Grid(g) => g.radiosity(),
        }
    }
}
