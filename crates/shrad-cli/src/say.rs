//! What the commands print on standard output, through [`say!`] instead of `println!`: a
//! reader that closes the pipe early (`shrad info room | head`) must not make shrad panic
//! ("failed printing to stdout: Broken pipe"). What is printed is a report beside the
//! command's job, so a closed pipe ends the report and the job goes on (a picture is still
//! written); any other failure to print (a full disk) is said once on standard error, and
//! the command then exits non-zero ([`failed`]).

use std::fmt::Arguments;
use std::io::{ErrorKind, Write};
use std::sync::atomic::{AtomicBool, Ordering};

/// Whether a failure to print was already said.
static WARNED: AtomicBool = AtomicBool::new(false);

/// Whether printing failed for another reason than a closed pipe.
pub fn failed() -> bool {
    WARNED.load(Ordering::Relaxed)
}

/// Print a line on standard output (the body of [`say!`]).
pub fn line(args: Arguments) {
    let result = writeln!(std::io::stdout().lock(), "{args}");
    if let Err(e) = result {
        if e.kind() != ErrorKind::BrokenPipe && !WARNED.swap(true, Ordering::Relaxed) {
            eprintln!("warning: cannot print to standard output: {e}");
        }
    }
}

/// `println!` that never panics: see the module's docs.
macro_rules! say {
    () => {
        $crate::say::line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::say::line(format_args!($($arg)*))
    };
}
