//! The GLB container: a 12-byte header, a JSON chunk, an optional BIN chunk, and chunks of
//! other types (skipped).
//!
//! Written through `gltf::Glb`. Read by hand, with every length checked against the file:
//! `gltf::Glb::from_slice` (gltf 1.4.1, `binary.rs`) computes `header.length - 12` unchecked,
//! which panics on a header that declares fewer than 12 bytes; and it refuses a chunk of an
//! unknown type after the JSON chunk, which the specification says a reader must skip.

use std::borrow::Cow;

/// The chunks of a GLB.
pub(super) struct Chunks<'a> {
    pub(super) json: &'a [u8],
    pub(super) bin: Option<&'a [u8]>,
    /// Bytes after the declared length.
    pub(super) warning: Option<String>,
}

/// Split a GLB into its JSON and BIN chunks, every length checked against the file.
pub(super) fn split_glb(bytes: &[u8]) -> Result<Chunks<'_>, String> {
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    let n = bytes.len();
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at.checked_add(4)?)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!(
            "GLB: the 12-byte header is truncated (the file has {n} bytes)"
        ));
    };
    if version != 2 {
        return Err(format!(
            "GLB: container version {version} (shrad reads glTF 2.0, GLB version 2)"
        ));
    }
    let length = length as usize;
    if length > n {
        return Err(format!(
            "GLB: the header declares {length} bytes but the file has {n} (truncated file?)"
        ));
    }
    let warning = (length < n).then(|| {
        format!(
            "GLB: {} byte(s) after the declared length ignored",
            n - length
        )
    });
    // (type, body, offset of the next chunk) of the chunk at `at`; None at the end.
    type Chunk<'b> = Option<(u32, &'b [u8], usize)>;
    let chunk = |at: usize| -> Result<Chunk<'_>, String> {
        if at == length {
            return Ok(None);
        }
        let (Some(len), Some(ty)) = (word(at), word(at + 4)) else {
            return Err(format!(
                "GLB: the chunk header at byte {at} is truncated (the GLB has {length} bytes)"
            ));
        };
        let start = at + 8;
        if start > length {
            return Err(format!(
                "GLB: the chunk header at byte {at} is truncated (the GLB has {length} bytes)"
            ));
        }
        let end = start
            .checked_add(len as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!(
                    "GLB: the chunk at byte {at} declares {len} bytes but only {} remain (truncated file?)",
                    length - start
                )
            })?;
        Ok(Some((ty, &bytes[start..end], end)))
    };
    let Some((ty, json, mut at)) = chunk(12)? else {
        return Err("GLB: no JSON chunk".into());
    };
    if ty != JSON {
        return Err(format!(
            "GLB: the first chunk is of type 0x{ty:08X}, not JSON"
        ));
    }
    let mut bin = None;
    while let Some((ty, body, next)) = chunk(at)? {
        match ty {
            BIN if bin.is_some() => return Err("GLB: more than one BIN chunk".into()),
            BIN => bin = Some(body),
            JSON => return Err("GLB: more than one JSON chunk".into()),
            // Chunks of other types are skipped, as the specification says.
            _ => {}
        }
        at = next;
    }
    Ok(Chunks { json, bin, warning })
}

/// A GLB of the glTF JSON `json` and the binary buffer `bin` (padded to 4 bytes): the one
/// GLB packer (scenes and bakes); an error when it would pass the format's 4 GiB.
pub fn join_glb(json: Vec<u8>, bin: Vec<u8>) -> Result<Vec<u8>, String> {
    // Header, two chunk headers, the JSON padded to 4 bytes, the buffer.
    let total = 28 + json.len().next_multiple_of(4) + bin.len();
    if u32::try_from(total).is_err() {
        return Err(format!(
            "GLB: {total} bytes is more than a GLB can hold (4 GiB)"
        ));
    }
    let glb = gltf::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            // Computed again by `to_vec`.
            length: 0,
        },
        json: Cow::Owned(json),
        bin: Some(Cow::Owned(bin)),
    };
    glb.to_vec().map_err(|e| format!("GLB: {e}"))
}
