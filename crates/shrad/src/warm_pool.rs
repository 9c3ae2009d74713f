//! Running a frame inside rayon's pool with its workers kept awake.
//!
//! A dispersive frame is some forty short parallel sections (a few hundred rays, a few
//! thousand patches each) between short serial ones. Called from outside the pool, each
//! section is injected into it and its caller sleeps until a worker has run it; and a
//! worker left idle for more than a few tens of microseconds goes to sleep, so the next
//! section waits for it to wake. Measured on this project's 2-core machine (a section of two
//! 50 us halves after a serial gap): 64-145 us from outside the pool, 52-87 us inside it,
//! 52-61 us inside it with the other worker kept awake as below. The 77k room's moving frame
//! ran only 1.2x faster on two threads than on one before this.
//!
//! [`warm`] runs a closure on a worker of the pool and, while it runs, keeps every other
//! worker spinning: each looks for pool work ([`rayon::yield_now`]) and runs it, so a
//! section's second half starts at once. A spinner never holds up what it runs on top of:
//! after `IDLE_TURN` without work it hands its place back (it queues itself again and
//! returns), and it ends when the closure does. The cost is the other cores' time during the
//! frame, which a frame on a machine of its own would spend waiting anyway. Between looks
//! it yields its core to the system (`std::thread::yield_now`), so that another process
//! that wants the core runs: with a busy wait, the viewer's engine, sharing two cores with
//! the browser that draws its pictures, ran faster on one thread than on two.
//!
//! A spinner runs whatever the pool holds, so nothing may be queued into the pool of a
//! frame that blocks until the frame ends: a spinner that picks it up never returns, and
//! the frame waits for its spinners. The Python binding once did (another thread's call took
//! the engine's lock inside the engine's own pool, and hung for good); it now takes the lock
//! on the calling thread. Wait outside the pool, never in it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long a spinner waits without work before it returns (and queues itself again), so
/// that a job it interrupted while waiting for its own halves may go on.
const IDLE_TURN: Duration = Duration::from_micros(50);

/// Run `f` inside rayon's pool with the other workers kept awake until it returns (see the
/// module's notes). With a single worker, `f` runs on it, without spinners.
pub fn warm<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    let threads = rayon::current_num_threads();
    if threads < 2 {
        // Still inside the pool: a parallel section called from outside it is handed to the
        // pool's one worker and waited for (a futex wake and sleep each: 10.5 against 8.2 ms
        // for the 77k room's moving frame on one thread).
        return rayon::scope(|_| f());
    }
    let active = &AtomicBool::new(true);
    rayon::scope(|s| {
        let owner = rayon::current_thread_index();
        for _ in 1..threads {
            s.spawn(move |s| keep_warm(s, active, owner));
        }
        let out = f();
        active.store(false, Ordering::Release);
        out
    })
}

/// Spin on this worker, running pool work as it comes, while `active`; queue itself again
/// after [`IDLE_TURN`] idle. On the thread that runs the closure (`owner`; it picks up a
/// spinner while waiting for work it shared) it returns at once: spinning there would hold
/// up the closure itself.
fn keep_warm<'s>(s: &rayon::Scope<'s>, active: &'s AtomicBool, owner: Option<usize>) {
    if rayon::current_thread_index() == owner {
        return;
    }
    let mut idle_since = Instant::now();
    while active.load(Ordering::Acquire) {
        match rayon::yield_now() {
            Some(rayon::Yield::Executed) => idle_since = Instant::now(),
            _ if idle_since.elapsed() > IDLE_TURN => {
                s.spawn(move |s| keep_warm(s, active, owner));
                return;
            }
            // The core back to the system, not a busy wait: on a machine of its own the
            // call returns at once, and where another process wants the core (the viewer's
            // browser on the same two) it gets it. With `spin_loop` the 77k room's frame
            // while the page dragged an object was 26-36 ms; with this 17-18.
            _ => std::thread::yield_now(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn gives_what_the_closure_gives_and_runs_parallel_work_inside() {
        let sum: u64 = warm(|| (0..100_000u64).into_par_iter().map(|x| x * x).sum());
        assert_eq!(sum, (0..100_000u64).map(|x| x * x).sum::<u64>());
    }

    #[test]
    fn nested_and_concurrent_frames_finish() {
        // Frames started from several threads at once, each with nested parallel work and
        // another warm section inside: every spinner ends with its frame, none deadlocks.
        let totals: Vec<u64> = (0..8u64)
            .into_par_iter()
            .map(|k| {
                warm(|| {
                    (0..64u64)
                        .into_par_iter()
                        .map(|i| {
                            warm(|| (0..100u64).into_par_iter().map(|j| i * j + k).sum::<u64>())
                        })
                        .sum()
                })
            })
            .collect();
        for (k, t) in totals.iter().enumerate() {
            let want: u64 = (0..64u64)
                .flat_map(|i| (0..100u64).map(move |j| i * j + k as u64))
                .sum();
            assert_eq!(*t, want);
        }
    }
}
