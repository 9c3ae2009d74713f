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
//! Only regular files are read, so memory stays bounded by what is on disk (a URI naming
//! `/dev/zero` or a pipe is refused).

use std::path::{Path, PathBuf};

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
        let length = b["byteLength"].as_u64().unwrap_or(0) as usize;
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
            Some(uri) => read(base, uri).map_err(|e| match e {
                UriError::Unreadable(m, kind) => SceneError::Unreadable {
                    path: path.to_path_buf(),
                    message: format!("buffers[{i}].uri: {m}"),
                    kind,
                },
                UriError::Invalid(m) => SceneError::invalid(path, format!("buffers[{i}].uri: {m}")),
            })?,
        };
        if data.len() < length {
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
    /// The URI itself is wrong, or names something that is not a regular file.
    Invalid(String),
}

impl std::fmt::Display for UriError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            UriError::Unreadable(m, _) | UriError::Invalid(m) => f.write_str(m),
        }
    }
}

/// The bytes behind a glTF URI: a base64 data URI or a file relative to `base`.
pub(super) fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    read(base, uri).map_err(|e| e.to_string())
}

fn read(base: &Path, uri: &str) -> Result<Vec<u8>, UriError> {
    if let Some(rest) = uri.strip_prefix("data:") {
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
    if uri.contains("://") && !uri.starts_with("file://") {
        return Err(UriError::Invalid(format!(
            "unsupported URI scheme in '{uri}'"
        )));
    }
    let file = base.join(relative_path(uri));
    let cannot = |e: std::io::Error| {
        UriError::Unreadable(format!("cannot read '{}': {e}", file.display()), e.kind())
    };
    // Only a regular file has a size to stop at: a device (`/dev/zero`) or a pipe would be
    // read without end.
    let meta = std::fs::metadata(&file).map_err(cannot)?;
    if !meta.is_file() {
        return Err(UriError::Invalid(format!(
            "cannot read '{}': not a regular file",
            file.display()
        )));
    }
    std::fs::read(&file).map_err(cannot)
}

/// The path a relative (or `file://`) URI names: percent-decoded, bytes that are not UTF-8
/// replaced.
fn relative_path(uri: &str) -> PathBuf {
    let raw = uri.strip_prefix("file://").unwrap_or(uri);
    PathBuf::from(String::from_utf8_lossy(&urlencoding::decode_binary(raw.as_bytes())).as_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uris_are_percent_decoded_leniently() {
        assert_eq!(relative_path("a%20b%2"), Path::new("a b%2"));
        assert_eq!(relative_path("%zz%41"), Path::new("%zzA"));
        assert_eq!(relative_path("file://x%2Fy.bin"), Path::new("x/y.bin"));
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
        // A device has no end: refused before reading (else this test would never finish).
        if Path::new("/dev/zero").exists() {
            let e = read_uri(&dir, "/dev/zero").unwrap_err();
            assert_eq!(e, "cannot read '/dev/zero': not a regular file");
        }
    }
}
