//! Ctrl-C for the library's long calls: building an `Engine`, `error()`'s reference solve,
//! `bake`. The library asks a [`shrad::Progress`] whether to stop (`stop_requested`) where it
//! reports progress, and then ends with `shrad::Error::Interrupted`, nothing made and no
//! file written.
//!
//! Python runs signal handlers (Ctrl-C's KeyboardInterrupt) only on the main thread, holding
//! the GIL (`Python::check_signals`), and the library calls its progress from rayon's workers,
//! which may neither take the GIL (the calling thread waits for them: a deadlock) nor block
//! (the engine's warm pool, `shrad::warm_pool`). So the work runs on a thread of its own
//! with the GIL released, and the calling thread wakes every [`POLL`] to run the handlers;
//! when one raises, it sets the flag the work's [`Stop`] reports, waits for the library to
//! stop at its next check, and raises the handler's exception. The workers only read an
//! atomic flag. (`converge` checks between frames on the calling thread instead: see
//! `PyEngine::converge_interruptible`.)

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

use pyo3::prelude::*;

use crate::to_py_err;

/// How often the calling thread runs the signal handlers while the work goes on.
const POLL: Duration = Duration::from_millis(50);

/// The progress a stoppable call hands the library: reports nothing; asks to stop once a
/// signal handler raised on the calling thread.
#[derive(Default)]
pub(crate) struct Stop(AtomicBool);

impl shrad::Progress for Stop {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
    fn stop_requested(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Run `work` on a thread of its own with the GIL released, running Python's signal
/// handlers on the calling thread meanwhile (module notes). A handler's exception
/// (KeyboardInterrupt) is raised once the work has stopped, and whatever it made is dropped;
/// otherwise the work's result, its error as the Python exception ([`to_py_err`]).
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&Stop) -> Result<T, shrad::Error> + Send,
) -> PyResult<T> {
    let stop = &Stop::default();
    py.detach(|| {
        std::thread::scope(|s| {
            let (done, result) = mpsc::channel();
            let worker = s.spawn(move || {
                let _ = done.send(work(stop));
            });
            let mut raised: Option<PyErr> = None;
            loop {
                match result.recv_timeout(POLL) {
                    Ok(out) => {
                        return match raised {
                            Some(e) => Err(e),
                            None => out.map_err(to_py_err),
                        }
                    }
                    Err(RecvTimeoutError::Timeout) if raised.is_none() => {
                        if let Err(e) = Python::attach(|py| py.check_signals()) {
                            stop.0.store(true, Ordering::Relaxed);
                            raised = Some(e);
                        }
                    }
                    Err(RecvTimeoutError::Timeout) => {}
                    // The work panicked (a library bug): on to the caller, as anywhere else.
                    Err(RecvTimeoutError::Disconnected) => {
                        let panic = worker.join().err();
                        std::panic::resume_unwind(
                            panic.unwrap_or_else(|| Box::new("the work ended without a result")),
                        )
                    }
                }
            }
        })
    })
}
