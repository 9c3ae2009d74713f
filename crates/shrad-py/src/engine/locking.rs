//! How every call reaches the engine: locked, with the GIL released, in the engine's own
//! thread pool (`threads=`) if it has one, and stoppable by Ctrl-C where the work is long.

use std::sync::MutexGuard;

use pyo3::prelude::*;
use shrad::engine::Engine;

use super::PyEngine;
use crate::args::ObjRef;
use crate::stop::Stop;
use crate::to_py_err;

impl PyEngine {
    /// Run `f` on the engine with the GIL released.
    /// The lock is taken on the calling thread, outside the engine's own pool: a thread that
    /// waits for it inside the pool held one of the pool's workers, and with `threads=2` a
    /// second Python thread's call during a frame hung both for good.
    pub(super) fn with<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut Engine) -> T + Send,
    ) -> T {
        py.detach(|| {
            let mut guard = self.lock();
            let e: &mut Engine = &mut guard;
            self.on_pool(|| f(e))
        })
    }

    /// [`PyEngine::with`] for long work that Ctrl-C stops ([`crate::stop`]): `f` runs on a
    /// thread of its own with the progress to hand the library, the engine locked there
    /// (outside the pool, as in `with`).
    pub(super) fn with_stoppable<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut Engine, &Stop) -> Result<T, shrad::Error> + Send,
    ) -> PyResult<T> {
        crate::stop::interruptible(py, |stop| {
            let mut guard = self.lock();
            let e: &mut Engine = &mut guard;
            self.on_pool(|| f(e, stop))
        })
    }

    /// Run `f` in the engine's own thread pool, if it has one.
    pub(super) fn on_pool<T: Send>(&self, f: impl FnOnce() -> T + Send) -> T {
        match &self.pool {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }

    pub(super) fn lock(&self) -> MutexGuard<'_, Engine> {
        // A panic inside the library (a bug) poisons the lock; the engine's state is still
        // whole (every mutation validates first, and a frame that panics has its solver
        // built again: `Engine::try_step_with_progress`), so go on with it.
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// `Engine::converge` with the GIL released, taking it back between frames to run the
    /// Python signal handlers on the calling thread (the library's loop alone would hold
    /// Ctrl-C back until the last frame): `Engine::converge_by` with a step that checks them.
    /// The engine stays locked throughout, so another thread's calls wait for the end as
    /// before (no deadlock: every call releases the GIL before it waits for the lock).
    pub(super) fn converge_interruptible(
        &self,
        py: Python<'_>,
        passes: usize,
    ) -> PyResult<Vec<shrad::frame::FrameStats>> {
        py.detach(|| {
            let mut guard = self.lock();
            guard.converge_by(passes, |e| {
                let stats = self.on_pool(|| e.step());
                Python::attach(|py| py.check_signals())?;
                Ok(stats)
            })
        })
    }

    pub(super) fn object(&self, py: Python<'_>, obj: &ObjRef) -> PyResult<usize> {
        match obj {
            ObjRef::Index(i) => {
                let n = self.with(py, |e| e.world().scene.objects.len());
                ObjRef::index_within(*i, n, "object")
            }
            ObjRef::Name(name) => self.with(py, |e| e.object(name)).map_err(to_py_err),
        }
    }
}
