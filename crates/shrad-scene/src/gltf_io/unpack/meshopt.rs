//! `EXT_meshopt_compression`: buffer views compressed by meshoptimizer's vertex and index
//! codecs (with an optional filter), decoded by meshopt-rs into the new buffer (the
//! QUATERNION filter by shrad: [`decode_quaternion`] says why). The view's
//! own `buffer` is then usually a placeholder without data (`"fallback": true`).
//!
//! Specification: KhronosGroup/glTF, `extensions/2.0/Vendor/EXT_meshopt_compression`.

use meshopt_rs::index::{buffer::decode_index_buffer, sequence::decode_index_sequence};
use meshopt_rs::vertex::buffer::decode_vertex_buffer;
use meshopt_rs::vertex::filter::{decode_filter_exp, decode_filter_oct_16, decode_filter_oct_8};
use serde_json::{json, Value};

use super::Unpack;

/// The two names of the extension: `KHR_meshopt_compression` is `EXT_meshopt_compression`
/// with a version 1 attribute codec and a COLOR filter added (its Appendix C).
const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// The extension's fields, checked.
struct Compressed {
    buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: String,
    filter: String,
}

/// Decode every compressed buffer view and make it a plain view of the new buffer.
pub(super) fn decode_views(u: &mut Unpack) -> Result<(), String> {
    let n = u.root["bufferViews"].as_array().map_or(0, Vec::len);
    for v in 0..n {
        let view = &u.root["bufferViews"][v];
        let Some((name, ext)) = EXTENSIONS.iter().find_map(|n| {
            view.pointer(&format!("/extensions/{n}"))
                .map(|e| (*n, e.clone()))
        }) else {
            continue;
        };
        let at = format!("bufferViews[{v}].extensions.{name}");
        let c = fields(&ext, &at, u.buffers.len())?;
        let view_len = u.root["bufferViews"][v]["byteLength"].as_u64().unwrap_or(0);
        let size = (c.count as u64).saturating_mul(c.stride as u64);
        if size > view_len {
            return Err(format!(
                "{at}: count {} x byteStride {} = {size} bytes is more than the bufferView's byteLength {view_len}",
                c.count, c.stride
            ));
        }
        u.budget(view_len, &at)?;
        let src = u.buffers[c.buffer]
            .get(c.offset..c.offset.saturating_add(c.length))
            .ok_or_else(|| {
                format!(
                    "{at}: bytes {}..{} lie outside buffer {} ({} bytes)",
                    c.offset,
                    c.offset.saturating_add(c.length),
                    c.buffer,
                    u.buffers[c.buffer].len()
                )
            })?;
        let mut bytes = decode(&c, src).map_err(|e| format!("{at}: cannot decode: {e}"))?;
        bytes.resize(view_len as usize, 0);
        let offset = u.append(&bytes);
        let view = &mut u.root["bufferViews"][v];
        view["buffer"] = json!(u.buffers.len());
        view["byteOffset"] = json!(offset);
        if let Some(exts) = view.get_mut("extensions").and_then(Value::as_object_mut) {
            exts.remove(name);
        }
    }
    Ok(())
}

fn fields(ext: &Value, at: &str, buffers: usize) -> Result<Compressed, String> {
    let uint = |key: &str, default: Option<u64>| -> Result<usize, String> {
        match ext.get(key) {
            None | Some(Value::Null) => default
                .map(|d| d as usize)
                .ok_or_else(|| format!("{at}.{key}: missing (required)")),
            Some(v) => v
                .as_u64()
                .and_then(|x| usize::try_from(x).ok())
                .ok_or_else(|| format!("{at}.{key}: {v} is not a non-negative integer")),
        }
    };
    let text = |key: &str, default: &str| -> Result<String, String> {
        match ext.get(key) {
            None | Some(Value::Null) => Ok(default.to_string()),
            Some(Value::String(s)) => Ok(s.clone()),
            Some(v) => Err(format!("{at}.{key}: {v} is not a string")),
        }
    };
    let c = Compressed {
        buffer: uint("buffer", None)?,
        offset: uint("byteOffset", Some(0))?,
        length: uint("byteLength", None)?,
        stride: uint("byteStride", None)?,
        count: uint("count", None)?,
        mode: text("mode", "")?,
        filter: text("filter", "NONE")?,
    };
    if c.buffer >= buffers {
        return Err(format!(
            "{at}.buffer: buffer {} does not exist (the file has {buffers})",
            c.buffer
        ));
    }
    let s = c.stride;
    let ok = match c.mode.as_str() {
        "ATTRIBUTES" => s > 0 && s <= 256 && s % 4 == 0,
        "TRIANGLES" => (s == 2 || s == 4) && c.count % 3 == 0,
        "INDICES" => s == 2 || s == 4,
        m => {
            return Err(format!(
                "{at}.mode: '{m}' is not ATTRIBUTES, TRIANGLES or INDICES"
            ))
        }
    };
    if !ok {
        return Err(format!(
            "{at}: byteStride {s} and count {} do not suit mode {} (ATTRIBUTES: a multiple of 4 up to 256; TRIANGLES: 2 or 4, count a multiple of 3; INDICES: 2 or 4)",
            c.count, c.mode
        ));
    }
    let filter_ok = match c.filter.as_str() {
        "NONE" => true,
        "OCTAHEDRAL" => s == 4 || s == 8,
        "QUATERNION" => s == 8,
        "EXPONENTIAL" => s % 4 == 0,
        "COLOR" => s == 4 || s == 8,
        f => {
            return Err(format!(
                "{at}.filter: '{f}' is not NONE, OCTAHEDRAL, QUATERNION, EXPONENTIAL or COLOR"
            ))
        }
    };
    if !filter_ok || (c.filter != "NONE" && c.mode != "ATTRIBUTES") {
        return Err(format!(
            "{at}.filter: {} does not apply to mode {} with byteStride {s}",
            c.filter, c.mode
        ));
    }
    Ok(c)
}

/// The decoded bytes (`count * stride`) of one view.
fn decode(c: &Compressed, src: &[u8]) -> Result<Vec<u8>, String> {
    let e = |e: &dyn std::fmt::Debug| format!("{e:?}");
    match (c.mode.as_str(), c.stride) {
        ("TRIANGLES", 2) => {
            let mut d = vec![0u32; c.count];
            decode_index_buffer(&mut d, src).map_err(|x| e(&x))?;
            narrow_u16(&d, "TRIANGLES")
        }
        ("TRIANGLES", _) => {
            let mut d = vec![0u32; c.count];
            decode_index_buffer(&mut d, src).map_err(|x| e(&x))?;
            Ok(d.iter().flat_map(|i| i.to_le_bytes()).collect())
        }
        ("INDICES", 2) => {
            let mut d = vec![0u32; c.count];
            decode_index_sequence(&mut d, src).map_err(|x| e(&x))?;
            narrow_u16(&d, "INDICES")
        }
        ("INDICES", _) => {
            let mut d = vec![0u32; c.count];
            decode_index_sequence(&mut d, src).map_err(|x| e(&x))?;
            Ok(d.iter().flat_map(|i| i.to_le_bytes()).collect())
        }
        _ => {
            // Version 1 (KHR_meshopt_compression), which meshopt-rs 0.1 does not know, by
            // shrad's decoder; version 0 by meshopt-rs.
            let mut words = match src.first() == Some(&super::attributes_v1::HEADER) {
                true => (super::attributes_v1::decode(c.stride, c.count, src)?.chunks_exact(4))
                    .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
                    .collect(),
                false => vertex_words(c.stride / 4, c.count, src).map_err(|x| e(&x))?,
            };
            filter(&c.filter, c.stride, &mut words);
            Ok(words.iter().flat_map(|w| w.to_le_bytes()).collect())
        }
    }
}

/// 16-bit indices, which the codec decodes as 32-bit ones.
fn narrow_u16(d: &[u32], mode: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(d.len() * 2);
    for &i in d {
        let i = u16::try_from(i)
            .map_err(|_| format!("{mode}: index {i} does not fit the 2-byte stride"))?;
        out.extend(i.to_le_bytes());
    }
    Ok(out)
}

/// The vertex codec decodes to a type of the vertex's size: `[u32; N]` for the stride 4N.
fn vertex_words_n<const N: usize>(
    count: usize,
    src: &[u8],
) -> Result<Vec<u32>, meshopt_rs::vertex::DecodeError> {
    let mut d = vec![[0u32; N]; count];
    decode_vertex_buffer(&mut d, src)?;
    Ok(d.into_iter().flatten().collect())
}

macro_rules! dispatch_words {
    ($n:expr, $count:expr, $src:expr; $($k:literal)*) => {
        match $n {
            $($k => vertex_words_n::<$k>($count, $src),)*
            _ => unreachable!("stride checked to be a multiple of 4 up to 256"),
        }
    };
}

/// Decoded vertices as little-endian words (`words` = stride / 4 in 1..=64).
fn vertex_words(
    words: usize,
    count: usize,
    src: &[u8],
) -> Result<Vec<u32>, meshopt_rs::vertex::DecodeError> {
    dispatch_words!(words, count, src;
        1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
        33 34 35 36 37 38 39 40 41 42 43 44 45 46 47 48 49 50 51 52 53 54 55 56 57 58 59 60 61
        62 63 64)
}

/// One colour of the COLOR filter (`KHR_meshopt_compression`, Appendix B, "Filter 4"), its
/// `bits`-bit components (8 or 16, as unsigned values): Y, Co, Cg (signed) and an alpha of
/// K-1 bits under a set bit K-1 that gives K; the output is R, G, B, A as unsigned
/// normalized `bits`-bit integers (clamped: the encoder keeps them in range).
fn decode_color(c: [u32; 4], bits: u32) -> [u32; 4] {
    let max = (1u32 << bits) - 1;
    let signed = |v: u32| ((v << (32 - bits)) as i32) >> (32 - bits);
    if c[3] == 0 {
        // No bit gives K: not a valid encoding.
        return [0; 4];
    }
    let k_max = (1i64 << (32 - c[3].leading_zeros())) - 1;
    let (y, co, cg) = (
        i64::from(c[0]),
        i64::from(signed(c[1])),
        i64::from(signed(c[2])),
    );
    let (r, g, b) = (y + co - cg, y + cg, y - co - cg);
    let a = i64::from(c[3]) & (k_max >> 1);
    let a = (a << 1) | (a & 1);
    let scale = f64::from(max) / k_max as f64;
    [r, g, b, a].map(|v| ((v as f64 * scale).round() as i64).clamp(0, i64::from(max)) as u32)
}

/// One quaternion of the QUATERNION filter (the specification's Appendix B, "Filter 2"):
/// components 0-2 are three of the quaternion's components, as *signed* K-bit integers
/// scaled by `1 / (sqrt(2) sf)`; component 3 holds `sf` (with its low two bits set) and, in
/// those two bits, which component was left out (the largest, made non-negative), which is
/// `sqrt(1 - x^2 - y^2 - z^2)`. The output is the four components as signed normalized
/// 16-bit integers. meshopt-rs 0.1's `decode_filter_quat` reads the components as
/// *unsigned* (a negative component became a large positive one): gltfpack's instance and
/// animation rotations came out wrong wherever a component was negative.
fn decode_quaternion(c: [i16; 4]) -> [i16; 4] {
    let sf = i32::from(c[3]) | 3;
    let scale = std::f32::consts::FRAC_1_SQRT_2 / sf as f32;
    let [x, y, z] = [c[0], c[1], c[2]].map(|v| f32::from(v) * scale);
    let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
    // Rounded to the nearest integer, halves away from zero, as the reference decoder.
    let snorm = |v: f32| (v * 32767.0).round() as i16;
    let left_out = (c[3] & 3) as usize;
    let mut out = [0i16; 4];
    out[(left_out + 1) & 3] = snorm(x);
    out[(left_out + 2) & 3] = snorm(y);
    out[(left_out + 3) & 3] = snorm(z);
    out[left_out] = snorm(w);
    out
}

/// Apply the extension's filter in place (stride checked to suit it).
fn filter(filter: &str, stride: usize, words: &mut [u32]) {
    match (filter, stride) {
        ("OCTAHEDRAL", 4) => {
            let mut v: Vec<[u8; 4]> = words.iter().map(|w| w.to_le_bytes()).collect();
            decode_filter_oct_8(&mut v);
            for (w, b) in words.iter_mut().zip(v) {
                *w = u32::from_le_bytes(b);
            }
        }
        ("QUATERNION", _) => {
            for p in words.chunks_exact_mut(2) {
                let (a, b) = (p[0].to_le_bytes(), p[1].to_le_bytes());
                let c = [[a[0], a[1]], [a[2], a[3]], [b[0], b[1]], [b[2], b[3]]]
                    .map(i16::from_le_bytes);
                let q = decode_quaternion(c).map(|x| x as u16);
                p[0] = u32::from(q[0]) | u32::from(q[1]) << 16;
                p[1] = u32::from(q[2]) | u32::from(q[3]) << 16;
            }
        }
        ("OCTAHEDRAL", _) => {
            let mut v: Vec<[u16; 4]> = words
                .chunks_exact(2)
                .map(|p| {
                    let (a, b) = (p[0].to_le_bytes(), p[1].to_le_bytes());
                    [
                        u16::from_le_bytes([a[0], a[1]]),
                        u16::from_le_bytes([a[2], a[3]]),
                        u16::from_le_bytes([b[0], b[1]]),
                        u16::from_le_bytes([b[2], b[3]]),
                    ]
                })
                .collect();
            decode_filter_oct_16(&mut v);
            for (p, q) in words.chunks_exact_mut(2).zip(v) {
                p[0] = u32::from(q[0]) | u32::from(q[1]) << 16;
                p[1] = u32::from(q[2]) | u32::from(q[3]) << 16;
            }
        }
        ("EXPONENTIAL", _) => decode_filter_exp(words),
        ("COLOR", 4) => {
            for w in words.iter_mut() {
                let c = w.to_le_bytes().map(u32::from);
                *w = u32::from_le_bytes(decode_color(c, 8).map(|x| x as u8));
            }
        }
        ("COLOR", _) => {
            for p in words.chunks_exact_mut(2) {
                let c = [p[0] & 0xffff, p[0] >> 16, p[1] & 0xffff, p[1] >> 16];
                let q = decode_color(c, 16);
                p[0] = q[0] | q[1] << 16;
                p[1] = q[2] | q[3] << 16;
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The filter's encoding of unit quaternion `q` with 12-bit components, as the
    /// specification describes it: the largest component is left out (the quaternion
    /// negated first if it is negative), the others scaled by `sqrt(2) sf`.
    fn encode(q: [f32; 4]) -> ([i16; 4], [f32; 4]) {
        let m = (0..4)
            .max_by(|&a, &b| q[a].abs().total_cmp(&q[b].abs()))
            .unwrap();
        let q = if q[m] < 0.0 { q.map(|v| -v) } else { q };
        let sf = 4095i16;
        let c =
            |k: usize| (q[(m + k) & 3] * std::f32::consts::SQRT_2 * f32::from(sf)).round() as i16;
        ([c(1), c(2), c(3), (sf & !3) | m as i16], q)
    }

    #[test]
    fn quaternions_with_negative_components_decode_to_themselves() {
        let n = |q: [f32; 4]| {
            let l = q.iter().map(|v| v * v).sum::<f32>().sqrt();
            q.map(|v| v / l)
        };
        for q in [
            n([0.1, -0.5, 0.3, -0.8]),
            n([-0.7, 0.0, 0.0, 0.7]),
            n([0.0, 0.0, -0.2958, 0.9553]),
            n([0.25, 0.25, 0.57, -0.74]),
            [0.0, 0.0, 0.0, 1.0],
        ] {
            let (c, want) = encode(q);
            let got = decode_quaternion(c);
            for k in 0..4 {
                // 12-bit components: within 1 / (sqrt(2) 4095) of the quaternion, about 6
                // units of the 16-bit output.
                let w = (want[k] * 32767.0).round();
                assert!(
                    (f32::from(got[k]) - w).abs() <= 8.0,
                    "{q:?}: got {got:?}, want {want:?}"
                );
            }
        }
    }
}
