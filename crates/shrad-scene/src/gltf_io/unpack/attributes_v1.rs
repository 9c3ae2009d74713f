//! meshoptimizer's attribute codec, version 1 (header `0xa1`): what `KHR_meshopt_compression`
//! adds to `EXT_meshopt_compression`'s version 0 (which meshopt-rs decodes, and 0.1 of it
//! does not know version 1). Written from the specification, KhronosGroup/glTF
//! `extensions/2.0/Khronos/KHR_meshopt_compression`, Appendix A, "Mode 0: attributes":
//!
//! - the stream: the header byte, attribute blocks, zero padding so that the tail is at
//!   least 24 bytes, and the tail: the baseline element, then one channel mode a 4 bytes;
//! - a block: at most `min((8192 / stride) & !15, 256)` elements; a control byte for each 4
//!   byte positions (2 bits each), then a data block per byte position of the element,
//!   whose deltas come in groups of 16;
//! - a data block by its control: 0 and 1 are 2 header bits a group choosing the group's
//!   encoding (control 0: zero, 1-, 2- or 4-bit sentinel; control 1: 1-, 2-, 4-bit sentinel
//!   or 16 bytes as they are), 2 is all zero, 3 is the block's bytes as they are;
//! - the deltas made values by the channel mode of their 4 bytes: 0 zigzag byte deltas, 1
//!   zigzag 16-bit deltas, 2 32-bit XOR with a rotation (the mode's high 4 bits).
//!
//! Every read is bounds-checked: a short or malformed stream is an error, never a panic,
//! and a stream whose blocks do not end where its tail begins is refused, as the
//! specification says.

/// The version 1 header byte.
pub(super) const HEADER: u8 = 0xa1;
/// The least size of the tail with its padding (version 1).
const TAIL_MIN: usize = 24;
/// Elements in a group of deltas.
const GROUP: usize = 16;

/// Decode `count` elements of `stride` bytes (a multiple of 4, checked by the caller) from
/// the version 1 stream `src`.
pub(super) fn decode(stride: usize, count: usize, src: &[u8]) -> Result<Vec<u8>, String> {
    if src.first() != Some(&HEADER) {
        return Err("not a version 1 attribute stream (header 0xa1)".into());
    }
    let channels = stride / 4;
    let tail = stride + channels;
    let padded = tail.max(TAIL_MIN);
    if src.len() < 1 + padded {
        return Err(format!(
            "{} bytes are too few for the header and a {padded}-byte tail",
            src.len()
        ));
    }
    let data_end = src.len() - padded;
    let (baseline, modes) = src[src.len() - tail..].split_at(stride);
    check_channel_modes(modes)?;
    let mut out = Vec::with_capacity(count.saturating_mul(stride));
    let mut prev = baseline.to_vec();
    let max_block = ((8192 / stride) & !(GROUP - 1)).min(256);
    let mut reader = Reader {
        src: &src[..data_end],
        pos: 1,
    };
    let mut deltas = vec![0u8; stride * max_block];
    let mut done = 0;
    while done < count {
        let n = (count - done).min(max_block);
        let groups = n.div_ceil(GROUP);
        let controls = reader.take(channels)?.to_vec();
        for k in 0..stride {
            let control = (controls[k / 4] >> (2 * (k % 4))) & 3;
            let d = &mut deltas[k * max_block..k * max_block + groups * GROUP];
            byte_block(&mut reader, control, n, d)?;
        }
        for i in 0..n {
            for (c, &mode) in modes.iter().enumerate() {
                let delta = |j: usize| deltas[(4 * c + j) * max_block + i];
                apply(
                    mode,
                    [delta(0), delta(1), delta(2), delta(3)],
                    &mut prev[4 * c..4 * c + 4],
                );
            }
            out.extend_from_slice(&prev);
        }
        done += n;
    }
    if reader.pos != data_end {
        return Err(format!(
            "the blocks end at byte {} but the tail begins at {data_end}",
            reader.pos
        ));
    }
    Ok(out)
}

/// The channel modes in the tail: 0 and 1 with high bits 0, or 2 (any rotation).
fn check_channel_modes(modes: &[u8]) -> Result<(), String> {
    for (c, &m) in modes.iter().enumerate() {
        let ok = match m & 15 {
            0 | 1 => m >> 4 == 0,
            2 => true,
            _ => false,
        };
        if !ok {
            return Err(format!(
                "channel {c} has mode byte {m:#04x}, which is not valid"
            ));
        }
    }
    Ok(())
}

/// Bytes read in order, bounds-checked.
struct Reader<'a> {
    src: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.src.len());
        let end = end.ok_or_else(|| {
            format!(
                "the stream ends before its tail (needed {n} bytes at {})",
                self.pos
            )
        })?;
        let s = &self.src[self.pos..end];
        self.pos = end;
        Ok(s)
    }
}

/// The deltas of one byte position of a block of `n` elements into `out` (`n` rounded up
/// to whole groups), as `control` says. The bytes as they are (control 3) are `n` of them,
/// not a whole number of groups (what gltfpack's streams hold: a 60-element block's literal
/// bytes are 60).
fn byte_block(r: &mut Reader, control: u8, n: usize, out: &mut [u8]) -> Result<(), String> {
    let groups = n.div_ceil(GROUP);
    match control {
        2 => out.fill(0),
        3 => {
            out[..n].copy_from_slice(r.take(n)?);
            out[n..].fill(0);
        }
        _ => {
            let header = r.take(groups.div_ceil(4))?;
            for (g, d) in out.chunks_exact_mut(GROUP).enumerate() {
                let mode = (header[g / 4] >> (2 * (g % 4))) & 3;
                let bits = match (control, mode) {
                    (0, 0) => 0,
                    (0, m) => 1 << (m - 1),
                    (_, m) => 1 << m,
                };
                group(r, bits, d)?;
            }
        }
    }
    Ok(())
}

/// One group of 16 deltas at `bits` bits each (0: all zero; 8: the bytes as they are; else
/// packed, a delta of all ones standing for the next extra byte).
fn group(r: &mut Reader, bits: u32, out: &mut [u8]) -> Result<(), String> {
    match bits {
        0 => out.fill(0),
        8 => out.copy_from_slice(r.take(GROUP)?),
        _ => {
            let packed = r.take(GROUP * bits as usize / 8)?;
            let sentinel = (1u8 << bits) - 1;
            for (i, d) in out.iter_mut().enumerate() {
                let v = match bits {
                    // 1 bit: least significant first; 2 and 4 bits: most significant first.
                    1 => (packed[i / 8] >> (i % 8)) & 1,
                    2 => (packed[i / 4] >> (6 - 2 * (i % 4))) & 3,
                    _ => (packed[i / 2] >> (4 - 4 * (i % 2))) & 15,
                };
                *d = if v == sentinel { r.take(1)?[0] } else { v };
            }
        }
    }
    Ok(())
}

/// Add one element's deltas of a channel (4 bytes) to the previous element's `prev`, by the
/// channel's mode.
fn apply(mode: u8, d: [u8; 4], prev: &mut [u8]) {
    match mode & 15 {
        0 => {
            for (p, d) in prev.iter_mut().zip(d) {
                *p = p.wrapping_add(unzigzag8(d));
            }
        }
        1 => {
            for h in 0..2 {
                let v = u16::from_le_bytes([d[2 * h], d[2 * h + 1]]);
                let p = u16::from_le_bytes([prev[2 * h], prev[2 * h + 1]]);
                let x = p.wrapping_add(unzigzag16(v));
                prev[2 * h..2 * h + 2].copy_from_slice(&x.to_le_bytes());
            }
        }
        _ => {
            // The specification's `rotate` (a left rotation) is the encoder's; its inverse
            // is the decoder's: meshoptimizer's own streams with a rotation (mode 0x42 in
            // the tests) decode only so.
            let v = u32::from_le_bytes(d).rotate_right(u32::from(mode >> 4));
            let p = u32::from_le_bytes([prev[0], prev[1], prev[2], prev[3]]);
            prev.copy_from_slice(&(p ^ v).to_le_bytes());
        }
    }
}

fn unzigzag8(v: u8) -> u8 {
    if v & 1 != 0 {
        !(v >> 1)
    } else {
        v >> 1
    }
}

fn unzigzag16(v: u16) -> u16 {
    if v & 1 != 0 {
        !(v >> 1)
    } else {
        v >> 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Streams meshoptimizer's own encoder wrote (`tests/data/compressed/meshopt-v1/
    /// encode.mjs`): 700 elements of 8 bytes whose channels it codes as 32-bit XOR deltas,
    /// without and with a rotation (channel modes 0x02 and 0x42), which gltfpack's files in
    /// `tests/compressed.rs` do not use. Each decodes to the data it was made from.
    #[test]
    fn meshoptimizers_xor_channels_decode_to_their_data() {
        let dir = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/compressed/meshopt-v1/"
        );
        for name in ["noise", "bitsrand"] {
            let stream = std::fs::read(format!("{dir}{name}.bin")).unwrap();
            let raw = std::fs::read(format!("{dir}{name}.raw")).unwrap();
            let modes = &stream[stream.len() - 2..];
            assert!(modes.iter().all(|m| m & 15 == 2), "{name}: modes {modes:?}");
            let got = decode(8, 700, &stream).unwrap();
            let first = got.iter().zip(&raw).position(|(a, b)| a != b);
            assert!(
                got.len() == raw.len() && first.is_none(),
                "{name}: first difference at byte {first:?}"
            );
        }
    }

    #[test]
    fn malformed_streams_are_errors() {
        let dir = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/compressed/meshopt-v1/"
        );
        let stream = std::fs::read(format!("{dir}noise.bin")).unwrap();
        // Not version 1.
        let mut v0 = stream.clone();
        v0[0] = 0xa0;
        assert!(decode(8, 700, &v0).is_err());
        // Too short for its tail, cut in the middle, and one byte too many.
        assert!(decode(8, 700, &stream[..20]).is_err());
        let mut cut = stream[..stream.len() / 2].to_vec();
        cut.extend_from_slice(&stream[stream.len() - 24..]);
        assert!(decode(8, 700, &cut).is_err());
        let mut long = stream.clone();
        long.insert(1, 0);
        assert!(decode(8, 700, &long).is_err());
        // A channel mode the specification does not define.
        let mut bad = stream.clone();
        let n = bad.len();
        bad[n - 1] = 0x03;
        assert!(decode(8, 700, &bad).unwrap_err().contains("channel 1"));
        // More elements than the stream holds.
        assert!(decode(8, 7000, &stream).is_err());
    }

    /// Random streams after a valid header, of every length up to 600 bytes, for strides
    /// and counts of every kind: each is decoded or refused, never a panic.
    #[test]
    fn random_streams_never_panic() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        for len in 0..600usize {
            for stride in [4, 8, 12, 16, 64, 256] {
                let mut stream: Vec<u8> = (0..len).map(|_| next() as u8).collect();
                if let Some(first) = stream.first_mut() {
                    *first = HEADER;
                }
                let count = (next() % 600) as usize;
                let _ = decode(stride, count, &stream);
            }
        }
    }
}
