//! Shared by every target: write the input into a per-process directory on a tmpfs and
//! call `shrad_scene::load` on it. An `Err` is fine; a panic (or abort, or a blow-up in
//! memory or time) is a bug.

use std::path::PathBuf;
use std::sync::OnceLock;

use shrad_scene::{load, LoadOptions};

/// This process's scratch directory (on /dev/shm when there is one, for speed).
pub fn scratch() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let root = if std::path::Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let dir = root.join(format!("shrad-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch directory");
        dir
    })
}

/// libFuzzer's panic hook aborts on every panic, even one caught on purpose: those inside
/// draco-oxide-decoder (an alpha; `gltf_io/unpack/draco.rs` catches them and refuses the
/// stream, see README "Findings") are let through to the catch, every other panic still
/// aborts. The same test as `crates/shrad-scene/tests/fuzz_regressions.rs`.
fn let_draco_panics_through() {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let fuzzer_hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let in_draco = std::backtrace::Backtrace::force_capture()
                .to_string()
                .contains("draco_oxide_decoder::");
            if !in_draco {
                fuzzer_hook(info);
            }
        }));
    });
}

/// Write `files` (name, bytes) into the scratch directory, removing `stale` names first,
/// then load `files[0]` both strictly and with `drop_degenerate`.
pub fn load_files(files: &[(&str, &[u8])], stale: &[&str]) {
    let_draco_panics_through();
    let dir = scratch();
    for name in stale {
        let _ = std::fs::remove_file(dir.join(name));
    }
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).expect("write scratch file");
    }
    let path = dir.join(files[0].0);
    let strict = load(&path, &LoadOptions::default());
    if strict.is_err() {
        let _ = load(
            &path,
            &LoadOptions {
                drop_degenerate: true,
                ..Default::default()
            },
        );
    }
}
