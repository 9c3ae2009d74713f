//! Writing pictures: PNG through exposure and sRGB (or the paper's linear min-max map),
//! and linear OpenEXR (never clamped or tone mapped). Files are written to a temporary name
//! beside the target and renamed, so a failure never leaves a half-written picture.

use std::path::Path;

use glam::Vec3;

use crate::render::Image;
use crate::Error;

/// How linear radiance becomes display colour in a PNG.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tonemap {
    /// Multiply by `scale` (or, for `None`, a scale that maps the 99th percentile of the
    /// luminance of non-emitter pixels to 0.9), then encode as sRGB; values above 1 clip.
    Exposure(Option<f32>),
    /// The paper's display map (paper 2.3.5): linear from [min, max] of the picture's
    /// non-emitter radiance to [0, 255], no gamma.
    MinMax,
}

impl Default for Tonemap {
    fn default() -> Self {
        Tonemap::Exposure(None)
    }
}

fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The exposure scale [`Tonemap::Exposure`]`(None)` would use for `image`.
pub fn auto_exposure(image: &Image) -> f32 {
    let mut lum: Vec<f32> = image
        .pixels
        .iter()
        .zip(&image.emitter)
        .filter(|(_, e)| !**e)
        .map(|(c, _)| luminance(*c))
        .filter(|l| *l > 0.0)
        .collect();
    if lum.is_empty() {
        return 1.0;
    }
    let k = ((lum.len() as f32 * 0.99) as usize).min(lum.len() - 1);
    let (_, p99, _) = lum.select_nth_unstable_by(k, f32::total_cmp);
    0.9 / p99.max(f32::MIN_POSITIVE)
}

fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit RGB pixels of `image` under `tonemap`.
pub fn to_rgb8(image: &Image, tonemap: Tonemap) -> Vec<u8> {
    match tonemap {
        Tonemap::Exposure(scale) => {
            let s = scale.unwrap_or_else(|| auto_exposure(image));
            image
                .pixels
                .iter()
                .flat_map(|c| {
                    (*c * s)
                        .to_array()
                        .map(|x| (srgb_encode(x) * 255.0 + 0.5) as u8)
                })
                .collect()
        }
        Tonemap::MinMax => {
            let vals = image
                .pixels
                .iter()
                .zip(&image.emitter)
                .filter(|(_, e)| !**e)
                .map(|(c, _)| *c);
            let (lo, hi) = vals.fold((f32::INFINITY, 0f32), |(lo, hi), c| {
                (lo.min(c.min_element()), hi.max(c.max_element()))
            });
            let lo = if lo.is_finite() { lo } else { 0.0 };
            let range = (hi - lo).max(f32::MIN_POSITIVE);
            image
                .pixels
                .iter()
                .flat_map(|c| {
                    c.to_array()
                        .map(|x| (((x - lo) / range).clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
                })
                .collect()
        }
    }
}

/// Every file is written whole or not at all, by the one [`shrad_scene::write_atomic`].
pub use shrad_scene::write_atomic;

impl From<shrad_scene::WriteError> for Error {
    fn from(e: shrad_scene::WriteError) -> Self {
        Error::Output(e.path, e.message)
    }
}

/// Write a PNG.
pub fn write_png(image: &Image, path: &Path, tonemap: Tonemap) -> Result<(), Error> {
    png_problem(image).map_or(Ok(()), |why| {
        Err(Error::Invalid(format!("{}: {why}", path.display())))
    })?;
    write_atomic(path, |tmp| png_into(image, tonemap, tmp)).map_err(Error::from)
}

/// Why `image` cannot be a PNG, if it cannot: a pixel that is not finite. (One NaN or
/// infinity made the exposure, or the min-max, NaN and the whole picture black, silently.)
pub fn png_problem(image: &Image) -> Option<String> {
    let k = image.pixels.iter().position(|p| !p.is_finite())?;
    let w = image.width.max(1) as usize;
    Some(format!(
        "pixel ({}, {}) is {}: a PNG's tone mapping needs finite radiance (an EXR keeps it \
         as it is)",
        k % w,
        k / w,
        image.pixels[k]
    ))
}

/// Fill `path` with the PNG of `image` (no atomic write: for [`write_atomic`] or
/// [`shrad_scene::StagedFiles`] to call, after [`png_problem`]).
pub fn png_into(image: &Image, tonemap: Tonemap, path: &Path) -> Result<(), String> {
    let rgb = to_rgb8(image, tonemap);
    image::save_buffer_with_format(
        path,
        &rgb,
        image.width,
        image.height,
        image::ColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| e.to_string())
}

/// Write a linear OpenEXR (RGB, 32-bit float): radiance `B / pi`, `L_e` for emitters, 0
/// for the background.
pub fn write_exr(image: &Image, path: &Path) -> Result<(), Error> {
    write_atomic(path, |tmp| exr_into(image, tmp)).map_err(Error::from)
}

/// Fill `path` with [`write_exr`]'s file (no atomic write, as [`png_into`]).
pub fn exr_into(image: &Image, path: &Path) -> Result<(), String> {
    let w = image.width as usize;
    exr::prelude::write_rgb_file(path, w, image.height as usize, |x, y| {
        let c = image.pixels[y * w + x];
        (c.x, c.y, c.z)
    })
    .map_err(|e| e.to_string())
}

/// Read a linear OpenEXR written by [`write_exr`] (or any RGB EXR), for comparisons.
pub fn read_exr(path: &Path) -> Result<Image, Error> {
    use exr::prelude::read_first_rgba_layer_from_file;
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
        |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
        },
    )
    .map_err(|e| crate::Error::Input(path.into(), e.to_string()))?;
    let size = img.layer_data.size;
    let (_, pixels) = img.layer_data.channel_data.pixels;
    Ok(crate::render::Image {
        width: size.width() as u32,
        height: size.height() as u32,
        emitter: vec![false; pixels.len()],
        pixels,
    })
}

/// Write an animated GIF of 8-bit RGB frames at `fps`.
pub fn write_gif(
    frames: &[Vec<u8>],
    width: u32,
    height: u32,
    fps: f32,
    path: &Path,
) -> Result<(), Error> {
    write_atomic(path, |tmp| gif_into(frames, (width, height), fps, tmp)).map_err(Error::from)
}

/// Fill `path` with [`write_gif`]'s file (no atomic write, as [`png_into`]).
pub fn gif_into(
    frames: &[Vec<u8>],
    (width, height): (u32, u32),
    fps: f32,
    path: &Path,
) -> Result<(), String> {
    use image::codecs::gif::{GifEncoder, Repeat};
    use image::{Delay, Frame, RgbaImage};
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut encoder = GifEncoder::new_with_speed(std::io::BufWriter::new(file), 10);
    encoder
        .set_repeat(Repeat::Infinite)
        .map_err(|e| e.to_string())?;
    let delay = Delay::from_numer_denom_ms(1000, fps.max(0.01).round().max(1.0) as u32);
    for rgb in frames {
        let rgba: Vec<u8> = rgb
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect();
        let img = RgbaImage::from_raw(width, height, rgba).ok_or("frame size mismatch")?;
        encoder
            .encode_frame(Frame::from_parts(img, 0, 0, delay))
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One pixel that is not finite is an error naming it, and nothing is written (it made
    /// the exposure NaN and the whole PNG black).
    #[test]
    fn a_png_of_a_pixel_that_is_not_finite_is_refused() {
        let mut pixels = vec![Vec3::splat(0.5); 12];
        pixels[7] = Vec3::new(f32::NAN, 0.0, 0.0);
        let image = Image {
            width: 4,
            height: 3,
            pixels,
            emitter: vec![false; 12],
        };
        let dir = std::env::temp_dir().join(format!("shrad-png-nan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("nan.png");
        for tonemap in [Tonemap::Exposure(None), Tonemap::MinMax] {
            let e = write_png(&image, &path, tonemap).unwrap_err().to_string();
            assert!(e.contains("pixel (3, 1) is [NaN"), "{e}");
        }
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
