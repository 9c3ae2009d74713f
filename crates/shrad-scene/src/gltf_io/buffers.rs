//! The bytes behind each buffer and image URI: the GLB's BIN chunk, a base64 data URI, or a
//! file beside the glTF.
//!
//! The decoding is the crates' (base64, with the gltf crate's alphabet; urlencoding, which the
//! gltf crate percent-decodes with), but not the loop around it: `gltf::import_buffers` (gltf
//! 1.4.1, `import.rs`) unwraps the percent-decoding of a relative URI, so a URI such as
//! `a%FF.bin` panics; its I/O errors name no file; and it pads every buffer with zeros to a
//! multiple of 4 before comparing it with `byteLength`, so a buffer up to 3 bytes short
//! passes.
//!
//! Only files in the folder of the glTF file and below are read: a URI that is absolute, a
//! URL (`file:`, `http:`, ...: any scheme but `data:`), or a relative path whose `..` leads
//! out of the folder is refused before anything is opened, and so is a file that resolves
//! outside the folder through a symbolic link. A glTF file (say from an unpacked archive)
//! must not read `/etc/passwd` or `~/.ssh/id_rsa` into a buffer, where an error message or
//! the scene would show its bytes.
//!
//! Only regular files are read, so memory stays bounded by what is on disk (a URI naming a
//! device or a pipe is refused), and of a buffer's file no more than its `byteLength`.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::SceneError;

/// Standard base64, as the gltf crate decodes data URIs, but like shrad's reader has always
/// been: the unused low bits of the last symbol are not checked.
const BASE64: base64::Config = base64::STANDARD.decode_allow_trailing_bits(true);

/// The data of every buffer of the raw JSON `root`: buffer 0 of a GLB without `uri` from its
/// BIN chunk `blob`, the others from their URIs (relative to `base`), each at least its
/// `byteLength` bytes. A buffer without `uri` that has no BIN chunk to refer to is a
/// placeholder (as `EXT_meshopt_compression` fallbacks are) and gets no data: a buffer view
/// that reads it is refused where it is read.
pub(super) fn load_buffers(
    path: &Path,
    base: &Path,
    root: &serde_json::Value,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut out = Vec::new();
    let buffers = root["buffers"].as_array().map_or(&[][..], Vec::as_slice);
    for (i, b) in buffers.iter().enumerate() {
        let length = b["byteLength"].as_u64().unwrap_or(0);
        let data = match b["uri"].as_str() {
            None if i == 0 => match blob.take() {
                Some(data) => data,
                None => {
                    out.push(Vec::new());
                    continue;
                }
            },
            None => {
                out.push(Vec::new());
                continue;
            }
            Some(uri) => read(base, uri, Some(length)).map_err(|e| match e {
                UriError::Unreadable(m, kind) => SceneError::Unreadable {
                    path: path.to_path_buf(),
                    message: format!("buffers[{i}].uri: {m}"),
                    kind,
                },
                UriError::Invalid(m) => SceneError::invalid(path, format!("buffers[{i}].uri: {m}")),
            })?,
        };
        if (data.len() as u64) < length {
            return Err(SceneError::invalid(
                path,
                format!(
                    "buffers[{i}]: has {} bytes but declares byteLength {length} (truncated file?)",
                    data.len(),
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Why a URI's bytes could not be had.
pub(super) enum UriError {
    /// The file it names could not be read (the message names it; the OS's kind of error).
    Unreadable(String, std::io::ErrorKind),
    /// The URI itself is wrong or refused, or names something that is not a regular file.
    Invalid(String),
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UriError::Unreadable(m, _) | UriError::Invalid(m) => f.write_str(m),
        }
    }
}

/// The bytes behind a glTF URI (an image's): a base64 data URI or a file in the folder
/// `base` (that of the glTF file) or below.
pub(super) fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    read(base, uri, None).map_err(|e| e.to_string())
}

/// What every refusal of a URI that leaves the folder ends with.
const ONLY_INSIDE: &str = "shrad reads only files in that folder and below";

/// The bytes behind `uri`: a data URI, or a file in `base` or below. Of a file, `length`
/// (a buffer's `byteLength`) bytes when given: a shorter file is refused, and of a longer
/// one no more is read.
fn read(base: &Path, uri: &str, length: Option<u64>) -> Result<Vec<u8>, UriError> {
    if let Some(rest) = uri
        .get(..5)
        .filter(|s| s.eq_ignore_ascii_case("data:"))
        .map(|_| &uri[5..])
    {
        // RFC 2397: `data:[<mediatype>][;base64],<data>`, the data percent-encoded unless
        // it is base64.
        let Some((header, data)) = rest.split_once(',') else {
            return Err(UriError::Invalid(
                "data URI has no ',' before its data (RFC 2397)".into(),
            ));
        };
        if header.ends_with(";base64") {
            return base64::decode_config(data, BASE64)
                .map_err(|e| UriError::Invalid(format!("data URI: invalid base64 ({e})")));
        }
        return Ok(urlencoding::decode_binary(data.as_bytes()).into_owned());
    }
    if let Some(scheme) = scheme(uri) {
        return Err(if scheme.eq_ignore_ascii_case("file") {
            outside(uri, "a file: URL names an absolute path")
        } else {
            UriError::Invalid(format!(
                "'{}' is a URL ({scheme}:), not a file in the folder of the glTF file; {ONLY_INSIDE} (and data: URIs)",
                uri.escape_debug()
            ))
        });
    }
    let rel = path_inside(uri)?;
    // What messages show: the path as the URI gives it (relative to the current folder
    // when the glTF file is given so).
    let file = base.join(&rel);
    let cannot = |e: std::io::Error| {
        UriError::Unreadable(format!("cannot read '{}': {e}", file.display()), e.kind())
    };
    // The path with every symbolic link resolved, which must still be inside the folder:
    // a link in the folder to a file outside it is refused as the path would be. (It is
    // also the path opened, so a link put in place after this check is not followed.)
    let folder = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    let real_folder = std::fs::canonicalize(folder).map_err(|e| {
        UriError::Unreadable(
            format!("cannot read the folder '{}': {e}", folder.display()),
            e.kind(),
        )
    })?;
    let real = std::fs::canonicalize(folder.join(&rel)).map_err(cannot)?;
    if !real.starts_with(&real_folder) {
        return Err(outside(uri, "through a symbolic link"));
    }
    // Only a regular file has a size to stop at: a device or a pipe would be read without
    // end.
    let meta = std::fs::metadata(&real).map_err(cannot)?;
    if !meta.is_file() {
        return Err(UriError::Invalid(format!(
            "cannot read '{}': not a regular file",
            file.display()
        )));
    }
    let size = meta.len();
    let want = match length {
        Some(n) if size < n => {
            return Err(UriError::Invalid(format!(
                "'{}' has {size} bytes, fewer than the buffer's byteLength {n} (truncated file?)",
                file.display()
            )))
        }
        Some(n) => n,
        None => size,
    };
    let mut data = Vec::new();
    data.try_reserve_exact(usize::try_from(want).unwrap_or(usize::MAX))
        .map_err(|_| {
            UriError::Invalid(format!(
                "cannot read '{}': its {want} bytes do not fit in memory",
                file.display()
            ))
        })?;
    std::fs::File::open(&real)
        .and_then(|f| f.take(want).read_to_end(&mut data))
        .map_err(cannot)?;
    Ok(data)
}

/// The refusal of `uri`, which leaves the folder of the glTF file, and why. (Shown with
/// control characters escaped, as is any text of the file.)
fn outside(uri: &str, why: &str) -> UriError {
    UriError::Invalid(format!(
        "'{}' refers to a file outside the folder of the glTF file ({why}); {ONLY_INSIDE}",
        uri.escape_debug()
    ))
}

/// The scheme of `uri` if it has one (RFC 3986: a letter, then letters, digits, `+`, `-`
/// or `.`, then `:`). A relative reference cannot have a `:` in its first segment, so
/// `a:b.bin` is a URL of scheme `a` (a file of that name is `./a:b.bin`); so is a Windows
/// path `C:\x.bin`, which is absolute.
fn scheme(uri: &str) -> Option<&str> {
    let (scheme, _) = uri.split_once(':')?;
    let mut chars = scheme.chars();
    let first = chars.next()?;
    (first.is_ascii_alphabetic()
        && chars.all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.')))
    .then_some(scheme)
}

/// The path a relative URI names, percent-decoded, with `.` and `..` resolved lexically:
/// refused if it is absolute or its `..` lead out of the folder.
fn path_inside(uri: &str) -> Result<PathBuf, UriError> {
    let mut rel = PathBuf::new();
    for c in relative_path(uri).components() {
        match c {
            Component::Prefix(_) | Component::RootDir => {
                return Err(outside(uri, "it is an absolute path"))
            }
            Component::CurDir => {}
            Component::ParentDir => {
                if !rel.pop() {
                    return Err(outside(uri, "its '..' components lead out of the folder"));
                }
            }
            Component::Normal(name) => rel.push(name),
        }
    }
    // The folder itself (`.`, or an empty URI): refused later as not a regular file.
    if rel.as_os_str().is_empty() {
        rel.push(".");
    }
    Ok(rel)
}

/// The path a relative URI names: percent-decoded, bytes that are not UTF-8 replaced.
fn relative_path(uri: &str) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(&urlencoding::decode_binary(uri.as_bytes())).as_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_are_percent_decoded_leniently() {
        assert_eq!(relative_path("a%20b%2"), Path::new("a b%2"));
        assert_eq!(relative_path("%zz%41"), Path::new("%zzA"));
        assert_eq!(relative_path("x%2Fy.bin"), Path::new("x/y.bin"));
        // Not UTF-8 once decoded: replaced, where the gltf crate's importer panics.
        assert_eq!(relative_path("a%FF.bin"), Path::new("a\u{FFFD}.bin"));
    }

    #[test]
    fn data_uris_are_standard_base64() {
        let base = Path::new(".");
        let uri = |b64: &str| format!("data:application/octet-stream;base64,{b64}");
        assert_eq!(read_uri(base, &uri("TWFu")).unwrap(), b"Man");
        assert_eq!(read_uri(base, &uri("TWE=")).unwrap(), b"Ma");
        // The unused bits of the last symbol are not checked ('F' rather than 'E').
        assert_eq!(read_uri(base, &uri("TWF=")).unwrap(), b"Ma");
        let e = read_uri(base, &uri("AA*A")).unwrap_err();
        assert!(e.starts_with("data URI: invalid base64"), "{e}");
        // Not base64: percent-encoded (RFC 2397).
        assert_eq!(
            read_uri(base, "data:application/gltf-buffer,0%00%ff").unwrap(),
            b"0\0\xff"
        );
        assert_eq!(read_uri(base, "data:,A").unwrap(), b"A");
        let e = read_uri(base, "data:application/octet-stream").unwrap_err();
        assert!(e.starts_with("data URI has no ','"), "{e}");
    }

    #[test]
    fn only_regular_files_are_read() {
        let dir = std::env::temp_dir();
        let e = read_uri(&dir, ".").unwrap_err();
        assert!(e.ends_with("not a regular file"), "{e}");
        let e = read_uri(&dir, "").unwrap_err();
        assert!(e.ends_with("not a regular file"), "{e}");
    }

    /// A fresh empty folder for one test.
    fn folder(name: &str) -> PathBuf {
        crate::test_folder(&format!("buffers-{name}"))
    }

    #[test]
    fn uris_leaving_the_folder_are_refused_before_anything_is_opened() {
        let base = Path::new("/nonexistent-shrad-folder/models");
        let outside = "refers to a file outside the folder of the glTF file";
        for (uri, why) in [
            ("/etc/passwd", "it is an absolute path"),
            ("%2Fetc%2Fpasswd", "it is an absolute path"),
            ("/dev/zero", "it is an absolute path"),
            ("../x.bin", "its '..' components lead out of the folder"),
            (
                "a/../../x.bin",
                "its '..' components lead out of the folder",
            ),
            (
                "..%2F..%2Fetc%2Fpasswd",
                "its '..' components lead out of the folder",
            ),
            ("./..", "its '..' components lead out of the folder"),
            ("file:///etc/passwd", "a file: URL names an absolute path"),
            ("FILE:x.bin", "a file: URL names an absolute path"),
        ] {
            let e = read_uri(base, uri).unwrap_err();
            assert_eq!(
                e,
                format!(
                    "'{uri}' {outside} ({why}); shrad reads only files in that folder and below"
                ),
            );
        }
        for (uri, scheme) in [
            ("http://127.0.0.1:1/x.bin", "http"),
            ("https://example.com/x.bin", "https"),
            ("C:\\x.bin", "C"),
            ("svn+ssh://host/x", "svn+ssh"),
        ] {
            let e = read_uri(base, uri).unwrap_err();
            assert!(
                e.starts_with(&format!("'{}' is a URL ({scheme}:)", uri.escape_debug())),
                "{e}"
            );
        }
        // Control characters in a URI are shown escaped.
        let e = read_uri(base, "/a\x1b[2Jb").unwrap_err();
        assert!(e.starts_with("'/a\\u{1b}[2Jb' refers"), "{e}");
        // Not a scheme (a relative reference): looked for in the folder.
        for uri in [":", "./a:b.bin", "1a:b.bin", "sub/../x.bin"] {
            let e = read_uri(base, uri).unwrap_err();
            assert!(e.starts_with("cannot read the folder"), "{uri}: {e}");
        }
    }

    #[test]
    fn files_in_the_folder_and_below_are_read() {
        let dir = folder("inside");
        std::fs::create_dir_all(dir.join("sub dir/ünï")).unwrap();
        std::fs::write(dir.join("a.bin"), b"top").unwrap();
        std::fs::write(dir.join("sub dir/ünï/b c.bin"), b"deep").unwrap();
        assert_eq!(read_uri(&dir, "a.bin").unwrap(), b"top");
        assert_eq!(read_uri(&dir, "./a.bin").unwrap(), b"top");
        assert_eq!(read_uri(&dir, "sub%20dir/../a.bin").unwrap(), b"top");
        assert_eq!(
            read_uri(&dir, "sub%20dir/%C3%BCn%C3%AF/b%20c.bin").unwrap(),
            b"deep"
        );
        assert_eq!(read_uri(&dir, "sub dir/ünï/b c.bin").unwrap(), b"deep");
        assert_eq!(read_uri(&dir, "sub%20dir/ünï/../../a.bin").unwrap(), b"top");
        // From a subfolder, `..` may climb back to the glTF file's folder but no further.
        let sub = dir.join("sub dir");
        assert_eq!(read_uri(&sub, "ünï/b%20c.bin").unwrap(), b"deep");
        assert!(read_uri(&sub, "../a.bin")
            .unwrap_err()
            .contains("'..' components lead out"));
    }

    #[test]
    fn a_buffer_file_is_read_up_to_its_byte_length() {
        let dir = folder("length");
        std::fs::write(dir.join("d.bin"), b"0123456789").unwrap();
        assert_eq!(read(&dir, "d.bin", Some(4)).ok().unwrap(), b"0123");
        assert_eq!(read(&dir, "d.bin", Some(10)).ok().unwrap(), b"0123456789");
        assert_eq!(read(&dir, "d.bin", Some(0)).ok().unwrap(), b"");
        let e = read(&dir, "d.bin", Some(11)).err().unwrap().to_string();
        assert_eq!(
            e,
            format!(
                "'{}' has 10 bytes, fewer than the buffer's byteLength 11 (truncated file?)",
                dir.join("d.bin").display()
            )
        );
        // A byteLength past what memory can hold is refused by the file's size first.
        let e = read(&dir, "d.bin", Some(u64::MAX))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("fewer than the buffer's byteLength"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn symbolic_links_are_followed_only_inside_the_folder() {
        use std::os::unix::fs::symlink;
        let root = folder("links");
        let dir = root.join("model");
        std::fs::create_dir_all(dir.join("textures")).unwrap();
        std::fs::write(root.join("secret.bin"), b"secret").unwrap();
        std::fs::write(dir.join("textures/t.bin"), b"inside").unwrap();
        // Inside to inside: read.
        symlink("textures/t.bin", dir.join("t.bin")).unwrap();
        symlink("textures", dir.join("tex")).unwrap();
        assert_eq!(read_uri(&dir, "t.bin").unwrap(), b"inside");
        assert_eq!(read_uri(&dir, "tex/t.bin").unwrap(), b"inside");
        // Inside to outside, a file or a folder: refused.
        symlink("../secret.bin", dir.join("s.bin")).unwrap();
        symlink(&root, dir.join("up")).unwrap();
        symlink("/dev/zero", dir.join("zero")).unwrap();
        for uri in ["s.bin", "up/secret.bin", "zero"] {
            let e = read_uri(&dir, uri).unwrap_err();
            assert_eq!(
                e,
                format!("'{uri}' refers to a file outside the folder of the glTF file (through a symbolic link); shrad reads only files in that folder and below"),
            );
        }
        // `tex/..` is the folder lexically, though `tex` is a link: still inside.
        assert_eq!(read_uri(&dir, "tex/../t.bin").unwrap(), b"inside");
        // The glTF file's folder given through a link: its files are inside it.
        symlink(&dir, root.join("link-to-model")).unwrap();
        assert_eq!(
            read_uri(&root.join("link-to-model"), "t.bin").unwrap(),
            b"inside"
        );
    }
}
