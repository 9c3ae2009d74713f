//! Whole files or nothing: every output of shrad (scenes, images, CSV, plots) is written to a
//! temporary file beside its destination and renamed into place.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

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
    let result = write(&tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(|e| e.to_string()));
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shrad-write-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
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

    #[test]
    fn a_missing_directory_or_no_file_name_is_an_error() {
        let d = dir("missing");
        let e = write_atomic(&d.join("nowhere/out.txt"), |_| Ok(())).unwrap_err();
        assert!(e.message.contains("does not exist"), "{e}");
        let e = write_atomic(Path::new("/"), |_| Ok(())).unwrap_err();
        assert_eq!(e.message, "not a file path");
    }
}
