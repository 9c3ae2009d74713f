//! Progress reporting for long steps. The library only calls this trait; the CLI draws bars.
//!
//! A front end can also ask long work to stop ([`Progress::stop_requested`]): Python's
//! Ctrl-C. The work that honours it returns [`Error::Interrupted`] and leaves nothing half
//! made (no engine, no file; an engine it worked on stays whole): setting up a solver
//! ([`crate::engine::Engine::new_with_progress`], [`crate::solver::Solver::new_with_progress`]),
//! the reference solve ([`crate::reference::try_solve`],
//! [`crate::engine::Engine::error_with_progress`], [`crate::engine::Engine::try_step_with_progress`])
//! and a bake ([`crate::bake::bake_with_progress`]). It is asked where the work already
//! reports progress, or between bounded pieces of it, so a stop comes within one of them.
//! Work that returns no error (a frame of [`crate::engine::Engine::step_with_progress`],
//! [`crate::reference::solve`]) reports progress but never stops: it runs with
//! [`Unstoppable`].

use crate::Error;

/// Receives progress of long library steps. Implementations must be cheap and thread-safe:
/// `advance` and `stop_requested` are called from worker threads (rayon's, inside the
/// engine's pool, where nothing may block: see [`crate::warm_pool`]).
pub trait Progress: Sync {
    /// A step named `label` with `total` units of work begins.
    fn begin(&self, label: &str, total: u64);
    /// `n` more units are done.
    fn advance(&self, n: u64);
    /// The current step is finished.
    fn end(&self);
    /// Whether the front end asks the work to stop (read an atomic flag; never block, never
    /// call into an interpreter). Once true it should stay true for the rest of the call.
    fn stop_requested(&self) -> bool {
        false
    }
}

/// `Err(Error::Interrupted)` when `progress` asks the work to stop.
pub fn check(progress: &dyn Progress) -> Result<(), Error> {
    if progress.stop_requested() {
        return Err(Error::Interrupted);
    }
    Ok(())
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoProgress;

impl Progress for NoProgress {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
}

/// Passes the progress on to the progress it holds but never asks to stop: the infallible
/// forms of stoppable work run with it (see the module's notes).
#[derive(Clone, Copy)]
pub struct Unstoppable<'a>(pub &'a dyn Progress);

impl Progress for Unstoppable<'_> {
    fn begin(&self, label: &str, total: u64) {
        self.0.begin(label, total);
    }
    fn advance(&self, n: u64) {
        self.0.advance(n);
    }
    fn end(&self) {
        self.0.end();
    }
}

/// The value of work run with an [`Unstoppable`] progress, whose only error is
/// [`Error::Interrupted`], and so has none.
pub(crate) fn uninterrupted<T>(result: Result<T, Error>) -> T {
    match result {
        Ok(value) => value,
        Err(e) => unreachable!("work that never stops stopped: {e}"),
    }
}
