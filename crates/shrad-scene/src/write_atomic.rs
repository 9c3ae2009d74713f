//! Whole files or nothing: every output of shrad (scenes, images, CSV, plots) is written to a
//! temporary file beside its destination and renamed into place ([`write_atomic`]); a set of
//! files that belong together (a `.gltf` and its `.bin`, a baked sequence) is all or nothing
//! ([`StagedFiles`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Whether two output paths name one file (as written, or once their folders are resolved).
pub fn same_file(a: &Path, b: &Path) -> bool {
    let resolved = |p: &Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
        let dir = std::fs::canonicalize(dir.unwrap_or(Path::new("."))).ok()?;
        Some(dir.join(p.file_name()?))
    };
    a == b || resolved(a).is_some_and(|a| resolved(b) == Some(a))
}

/// Every temporary and staged file this process is writing or holds, for
/// [`remove_unfinished`] when it is stopped by a signal (Ctrl-C in a long bake left the
/// staged files of its sequence, hidden, beside the outputs).
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary or staged file, listed in [`UNFINISHED`] while it lives.
#[derive(Debug)]
struct Unfinished(PathBuf);

impl Unfinished {
    fn new(path: PathBuf) -> Unfinished {
        let mut list = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
        list.push(path.clone());
        Unfinished(path)
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        let mut list = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(k) = list.iter().rposition(|p| *p == self.0) {
            list.swap_remove(k);
        }
    }
}

/// Remove every temporary and staged file of outputs not yet finished: what a command
/// stopped by a signal calls before it exits, so that no part of an output stays.
pub fn remove_unfinished() {
    let list = UNFINISHED.lock().unwrap_or_else(|e| e.into_inner());
    for path in list.iter() {
        let _ = std::fs::remove_file(path);
    }
}

/// A file that could not be written; nothing was left behind at `path` or beside it.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write: {message}", path.display())]
pub struct WriteError {
    /// The destination.
    pub path: PathBuf,
    /// What went wrong.
    pub message: String,
}

/// A temporary path beside `path`, unique to this call, that keeps the extension (image
/// encoders and ffmpeg pick the format from it). `None` when `path` names no file.
fn temp_path(path: &Path) -> Option<PathBuf> {
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let name = path.file_name()?.to_string_lossy();
    let n = CALLS.fetch_add(1, Ordering::Relaxed);
    let tmp = path.with_file_name(format!(".{name}.partial-{}-{n}", std::process::id()));
    Some(match path.extension() {
        Some(ext) => tmp.with_extension(ext),
        None => tmp,
    })
}

/// Write `path` whole or not at all: `write` fills a temporary file in the same directory
/// (it is given that file's path), which is then renamed to `path`. When `write` or the
/// rename fails, the temporary file is removed and the error says why.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), WriteError> {
    let fail = |message: String| WriteError {
        path: path.to_path_buf(),
        message,
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            return Err(fail(format!("directory {} does not exist", dir.display())));
        }
    }
    let tmp = temp_path(path).ok_or_else(|| fail("not a file path".into()))?;
    // A device or a pipe (`-o /dev/null`) is written into, from a temporary file in the
    // temporary directory (its own may not be writable): a rename would put a regular file
    // in its place, and as root `-o /dev/null` once did.
    let special = is_special(path);
    let tmp = match special {
        true => std::env::temp_dir().join(tmp.file_name().unwrap_or_default()),
        false => tmp,
    };
    let put = |tmp: &Path| match special {
        true => copy_into(tmp, path),
        false => std::fs::rename(tmp, path),
    };
    let listed = Unfinished::new(tmp.clone());
    let result = write(&tmp).and_then(|()| put(&tmp).map_err(|e| e.to_string()));
    let _ = std::fs::remove_file(&tmp);
    drop(listed);
    result.map_err(fail)
}

/// Whether `path` is there and is neither a regular file nor a folder: a device, a pipe or
/// a socket, which an output is written into rather than renamed over.
fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Copy the finished file `from` into the device or pipe `to`.
fn copy_into(from: &Path, to: &Path) -> std::io::Result<()> {
    let mut src = std::fs::File::open(from)?;
    let mut dst = std::fs::OpenOptions::new().write(true).open(to)?;
    std::io::copy(&mut src, &mut dst).map(|_| ())
}

/// The hidden name [`StagedFiles`] writes `dest` under until it commits: in the same folder
/// (so the rename into place is atomic), `.out_0003.glb.staged-PID`; for a device or a pipe
/// (`-o /dev/null`), which is copied into, in the temporary directory (its own, `/dev`, is
/// not a user's to write in).
pub fn staged_path(dest: &Path) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let staged = format!(".{name}.staged-{}", std::process::id());
    match is_special(dest) {
        true => std::env::temp_dir().join(staged),
        false => dest.with_file_name(staged),
    }
}

/// Several files all or nothing, the companion of [`write_atomic`]. Each is written whole
/// (through [`write_atomic`]) under its [`staged_path`]; only [`StagedFiles::commit`], once
/// every file is staged, renames them into place, in the order they were staged. Dropped
/// without a commit (an error partway, a panic), it removes the staged files: no file of the
/// set is left on disk, and files of an earlier set at those names stay as they were.
#[derive(Debug, Default)]
#[must_use = "staged files are removed unless committed"]
pub struct StagedFiles {
    /// (staged name, destination), in staging order.
    files: Vec<(PathBuf, PathBuf)>,
    /// The staged names, listed for [`remove_unfinished`] until committed or removed.
    listed: Vec<Unfinished>,
}

impl StagedFiles {
    /// No file staged yet.
    pub fn new() -> StagedFiles {
        StagedFiles::default()
    }

    /// Write `dest`'s staged name with `write` (given the path to fill, as for
    /// [`write_atomic`]). The error names `dest`.
    pub fn stage(
        &mut self,
        dest: &Path,
        write: impl FnOnce(&Path) -> Result<(), String>,
    ) -> Result<(), WriteError> {
        let staged = staged_path(dest);
        // Listed before it exists: listed only once written, a Ctrl-C between the rename to
        // its staged name and the listing left it behind (seen once in a test's bake).
        let listed = Unfinished::new(staged.clone());
        write_atomic(&staged, write).map_err(|e| WriteError {
            path: dest.to_path_buf(),
            message: e.message,
        })?;
        self.listed.push(listed);
        self.files.push((staged, dest.to_path_buf()));
        Ok(())
    }

    /// [`StagedFiles::stage`] of `bytes`.
    pub fn stage_bytes(&mut self, dest: &Path, bytes: &[u8]) -> Result<(), WriteError> {
        self.stage(dest, |t| {
            std::fs::write(t, bytes).map_err(|e| e.to_string())
        })
    }

    /// Rename every staged file into place, in order, but a device or a pipe first (it is
    /// written into, and `/dev/full` refuses: failing before any file is renamed, it leaves
    /// every file of an earlier set as it was). When a rename fails (rare: each is in its
    /// destination's folder), the files not yet renamed are removed, and so are those
    /// already renamed: what was at their names before is gone, but no part of the set stays.
    pub fn commit(mut self) -> Result<(), WriteError> {
        let mut files = std::mem::take(&mut self.files);
        files.sort_by_key(|(_, dest)| !is_special(dest));
        for (i, (staged, dest)) in files.iter().enumerate() {
            let put = match is_special(dest) {
                true => copy_into(staged, dest).and_then(|()| std::fs::remove_file(staged)),
                false => std::fs::rename(staged, dest),
            };
            if let Err(e) = put {
                for (later, _) in &files[i..] {
                    let _ = std::fs::remove_file(later);
                }
                // (Never a device or a pipe: only what this set renamed into place.)
                for (_, done) in files[..i].iter().filter(|(_, d)| !is_special(d)) {
                    let _ = std::fs::remove_file(done);
                }
                return Err(WriteError {
                    path: dest.clone(),
                    message: e.to_string(),
                });
            }
        }
        Ok(())
    }
}

impl Drop for StagedFiles {
    fn drop(&mut self) {
        for (staged, _) in &self.files {
            let _ = std::fs::remove_file(staged);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        crate::test_folder(&format!("write-{name}"))
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_through_a_sibling_that_keeps_the_extension() {
        let d = dir("ok");
        let path = d.join("out.png");
        let mut seen = PathBuf::new();
        write_atomic(&path, |tmp| {
            seen = tmp.to_path_buf();
            std::fs::write(tmp, b"data").map_err(|e| e.to_string())
        })
        .unwrap();
        assert_eq!(seen.parent(), Some(d.as_path()));
        assert_eq!(seen.extension().unwrap(), "png");
        assert_eq!(std::fs::read(&path).unwrap(), b"data");
        assert_eq!(entries(&d), ["out.png"]);
    }

    #[test]
    fn a_failed_write_leaves_nothing_and_keeps_the_old_file() {
        let d = dir("fail");
        let path = d.join("out.csv");
        std::fs::write(&path, b"old").unwrap();
        let e = write_atomic(&path, |tmp| {
            std::fs::write(tmp, b"half").unwrap();
            Err("encoder failed".into())
        })
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{}: cannot write: encoder failed", path.display())
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(&d), ["out.csv"]);
    }

    /// A pipe (as `/dev/null` or `/dev/stdout` would be) is written into, and stays a pipe:
    /// a rename put a regular file in place of `/dev/null` once. (A FIFO of its own, not
    /// `/dev/null`: a failure must not break the machine.)
    #[test]
    fn a_device_or_pipe_is_written_into_not_replaced() {
        use std::io::Read;
        use std::os::unix::fs::FileTypeExt;
        let d = dir("fifo");
        let fifo = d.join("out.png");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo");
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || {
                let mut got = Vec::new();
                std::fs::File::open(&fifo)
                    .unwrap()
                    .read_to_end(&mut got)
                    .unwrap();
                got
            })
        };
        write_atomic(&fifo, |tmp| {
            assert_eq!(tmp.extension().unwrap(), "png");
            std::fs::write(tmp, b"picture").map_err(|e| e.to_string())
        })
        .unwrap();
        // (Checked before the reader is joined: had the pipe been renamed over, its reader
        // would wait for a writer for ever.)
        let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(kind.is_fifo(), "replaced by {kind:?}");
        assert_eq!(entries(&d), ["out.png"], "no temporary file left beside it");
        assert_eq!(reader.join().unwrap(), b"picture");
    }

    #[test]
    fn a_missing_directory_or_no_file_name_is_an_error() {
        let d = dir("missing");
        let e = write_atomic(&d.join("nowhere/out.txt"), |_| Ok(())).unwrap_err();
        assert!(e.message.contains("does not exist"), "{e}");
        let e = write_atomic(Path::new("/"), |_| Ok(())).unwrap_err();
        assert_eq!(e.message, "not a file path");
    }

    #[test]
    fn a_device_is_staged_in_the_temporary_directory_and_written_into() {
        // Beside it, in /dev, a user may not write (`render -o /dev/null` as one failed).
        let null = Path::new("/dev/null");
        assert!(staged_path(null).starts_with(std::env::temp_dir()));
        let d = dir("staged-device");
        let file = d.join("out.png");
        let mut set = StagedFiles::new();
        set.stage_bytes(&file, b"png").unwrap();
        set.stage_bytes(null, b"exr").unwrap();
        set.commit().unwrap();
        assert_eq!(entries(&d), ["out.png"]);
        assert!(!staged_path(null).exists());
    }

    #[test]
    fn staged_files_are_all_or_nothing() {
        let d = dir("staged");
        let (a, b) = (d.join("a.gltf"), d.join("a.bin"));
        std::fs::write(&a, b"old").unwrap();
        // Dropped before the commit: nothing new, the old file as it was.
        let mut set = StagedFiles::new();
        set.stage_bytes(&b, b"bin").unwrap();
        set.stage_bytes(&a, b"json").unwrap();
        assert_eq!(entries(&d).len(), 3, "a.gltf and two staged files");
        drop(set);
        assert_eq!(entries(&d), ["a.gltf"]);
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        // A file that cannot be staged (a folder holds its staged name) names its destination.
        std::fs::create_dir(staged_path(&b)).unwrap();
        let mut set = StagedFiles::new();
        set.stage_bytes(&a, b"json").unwrap();
        let e = set.stage_bytes(&b, b"bin").unwrap_err();
        assert_eq!(e.path, b);
        drop(set);
        std::fs::remove_dir(staged_path(&b)).unwrap();
        assert_eq!(entries(&d), ["a.gltf"]);
        // A rename that fails (a folder at the second name) takes the first back out.
        std::fs::create_dir(&b).unwrap();
        let mut set = StagedFiles::new();
        set.stage_bytes(&a, b"json").unwrap();
        set.stage_bytes(&b, b"bin").unwrap();
        let e = set.commit().unwrap_err();
        assert_eq!(e.path, b);
        assert_eq!(entries(&d), ["a.bin"]);
        std::fs::remove_dir(&b).unwrap();
        // Committed: both in place, nothing staged left.
        let mut set = StagedFiles::new();
        set.stage_bytes(&b, b"bin").unwrap();
        set.stage_bytes(&a, b"json").unwrap();
        set.commit().unwrap();
        assert_eq!(entries(&d), ["a.bin", "a.gltf"]);
        assert_eq!(std::fs::read(&a).unwrap(), b"json");
    }
}
