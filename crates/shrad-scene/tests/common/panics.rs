//! A panic hook that counts every panic on the test's thread, even those a reader's own
//! `catch_unwind` guard catches (which would otherwise hide them). Panics inside
//! draco-oxide-decoder are counted apart: with debug assertions that alpha panics on some
//! corrupt streams (a shift by a quantization bit count >= 64), and the Draco step catches
//! those and refuses the stream (`gltf_io/unpack/draco.rs`); they are not shrad's.

use std::cell::Cell;
use std::sync::Once;

thread_local! {
    static OUTSIDE_DRACO: Cell<usize> = const { Cell::new(0) };
    static IN_DRACO: Cell<usize> = const { Cell::new(0) };
}

/// The panics counted on this thread so far.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Panics {
    /// Outside draco-oxide-decoder: shrad's, or another crate's (reported as usual).
    pub outside_draco: usize,
    /// Inside draco-oxide-decoder (not reported).
    pub in_draco: usize,
}

/// Install the counting hook (once per process; the default hook still reports every
/// panic outside draco-oxide-decoder).
pub fn count_panics() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let in_draco = std::backtrace::Backtrace::force_capture()
                .to_string()
                .contains("draco_oxide_decoder::");
            if in_draco {
                IN_DRACO.with(|p| p.set(p.get() + 1));
            } else {
                OUTSIDE_DRACO.with(|p| p.set(p.get() + 1));
                default(info);
            }
        }));
    });
}

/// The panics counted on this thread so far (see [`count_panics`]).
pub fn panics() -> Panics {
    Panics {
        outside_draco: OUTSIDE_DRACO.with(Cell::get),
        in_draco: IN_DRACO.with(Cell::get),
    }
}
