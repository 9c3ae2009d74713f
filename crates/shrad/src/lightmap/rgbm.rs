//! RGBM: the lightmap's linear, unclamped values in an 8-bit RGBA PNG, for pipelines that
//! take no float texture (`shrad bake --lightmap --lightmap-format rgbm`).
//!
//! A texel's value (`E / pi`, W/m^2/sr, as in the EXR) is
//!
//! ```text
//! value = (r, g, b) * a * multiplier        r, g, b, a = byte / 255, linear
//! ```
//!
//! the encoding of three.js's `RGBMLoader` (`rgb * a * maxRange`) with the multiplier
//! chosen per lightmap: the smallest power of two at least the lightmap's largest value, so
//! no texel clips. It is stated in the glTF (`asset.extras.shrad.lightmap.rgbm`) and printed
//! by `shrad bake`; three.js's loader takes a fixed `maxRange` (7 or 16), so a three.js page
//! multiplies its `lightMapIntensity` by `multiplier / maxRange`. The bytes are linear (not
//! sRGB) and not premultiplied: a loader that premultiplies alpha (a browser's `<img>`)
//! destroys them, `RGBMLoader` does not.
//!
//! Precision: `a` is rounded up and `r, g, b` to nearest, so a channel is within
//! `0.5 / 255 * a * multiplier` of its value ([`tolerance`]): 8 bits of the texel's own
//! brightest channel, not of the multiplier. Values below `0.5 multiplier / 255^2` are lost.

use glam::Vec3;

/// The multiplier of `values`: the smallest power of two at least their largest finite
/// channel (1 when none is positive).
pub fn multiplier(values: &[Vec3]) -> f32 {
    let top = values
        .iter()
        .flat_map(|v| v.to_array())
        .filter(|x| x.is_finite())
        .fold(0.0f32, f32::max);
    if top > 0.0 {
        top.log2().ceil().exp2().max(f32::MIN_POSITIVE)
    } else {
        1.0
    }
}

/// The RGBA bytes of `value` under `multiplier` (negative or non-finite channels as 0;
/// values above the multiplier clip).
pub fn encode(value: Vec3, multiplier: f32) -> [u8; 4] {
    let v = value
        .to_array()
        .map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 });
    let top = (v[0].max(v[1]).max(v[2]) / multiplier).clamp(0.0, 1.0);
    let a = (top * 255.0).ceil();
    if a < 1.0 {
        return [0; 4];
    }
    let scale = a / 255.0 * multiplier;
    let [r, g, b] = v.map(|x| ((x / scale).clamp(0.0, 1.0) * 255.0).round() as u8);
    [r, g, b, a as u8]
}

/// The value of RGBA bytes `px` under `multiplier`.
pub fn decode(px: [u8; 4], multiplier: f32) -> Vec3 {
    let [r, g, b, a] = px.map(|x| x as f32 / 255.0);
    Vec3::new(r, g, b) * (a * multiplier)
}

/// The largest error of a channel decoded from `px`: half a step of its 8 bits.
pub fn tolerance(px: [u8; 4], multiplier: f32) -> f32 {
    0.5 / 255.0 * (px[3] as f32 / 255.0) * multiplier
}

/// An RGBA PNG of `values` (row by row, `width` x `height`) under `multiplier`.
pub fn png(values: &[Vec3], width: u32, height: u32, multiplier: f32) -> Result<Vec<u8>, String> {
    let bytes: Vec<u8> = values.iter().flat_map(|&v| encode(v, multiplier)).collect();
    let mut out = Vec::new();
    image::RgbaImage::from_raw(width, height, bytes)
        .ok_or("RGBM lightmap image size")?
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values from the multiplier down to its 255^2-th part decode within the stated
    /// tolerance; the multiplier is a power of two that clips nothing.
    #[test]
    fn round_trip_within_half_a_step() {
        let values: Vec<Vec3> = (0..2000)
            .map(|k| {
                let x = 10f32.powf(-4.0 + 5.0 * k as f32 / 2000.0);
                Vec3::new(x, 0.37 * x, 0.01 * x)
            })
            .collect();
        let m = multiplier(&values);
        assert_eq!(m, 16.0);
        for v in values {
            let px = encode(v, m);
            let back = decode(px, m);
            let tol = tolerance(px, m);
            assert!(
                (back - v).abs().max_element() <= tol * 1.0001,
                "{v} -> {px:?} -> {back}"
            );
        }
    }

    #[test]
    fn black_negative_and_non_finite_are_zero() {
        assert_eq!(multiplier(&[Vec3::ZERO, Vec3::splat(f32::NAN)]), 1.0);
        assert_eq!(encode(Vec3::ZERO, 4.0), [0; 4]);
        assert_eq!(
            encode(Vec3::new(-1.0, f32::NAN, f32::INFINITY), 4.0),
            [0; 4]
        );
        assert_eq!(multiplier(&[Vec3::new(0.3, 4.0, 1.0)]), 4.0);
        assert_eq!(multiplier(&[Vec3::new(0.3, 4.01, 1.0)]), 8.0);
    }
}
