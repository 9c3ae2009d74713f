//! Textures (spec section 2, "Textures"): a decoded image shared between materials, and how
//! a material samples it (texture-coordinate set, wrap modes, filter, `KHR_texture_transform`).
//!
//! **Memory.** An image is decoded once at load and kept as 8-bit sRGB RGB, 3 bytes a texel;
//! a sample is made linear through a 256-entry table (exactly the sRGB decode of each 8-bit
//! value, so nothing is lost for the 8-bit PNG and JPEG files glTF uses). A 4096 x 4096
//! texture costs 48 MiB (f32 linear RGB would be 192 MiB, RGB f16 96 MiB). 16-bit PNGs are
//! quantised to 8 bits (an error below 0.2 % of the sRGB value). Alpha is dropped (patches
//! are opaque), except for an image a glTF `alphaMode: MASK` material uses as its base
//! colour, and an OBJ `map_d` (its chosen channel as the alpha plane): those keep an alpha
//! plane (1 byte a texel) that the loader cuts the surface by (`cutout.rs`). Materials that
//! use the same image hold the same [`std::sync::Arc`].

use std::sync::{Arc, OnceLock};

use glam::{Vec2, Vec3};

/// A decoded image: 8-bit sRGB RGB texels, row-major from the top-left texel (glTF's UV
/// origin).
#[derive(Clone)]
pub struct TextureImage {
    /// Where it came from (the glTF image index and name or URI, the MTL map path).
    pub name: String,
    width: u32,
    height: u32,
    /// `r, g, b` bytes of each texel.
    texels: Vec<u8>,
    /// The alpha byte of each texel, kept only when asked for ([`TextureImage::decode_with`])
    /// and the image has an alpha channel; None: every texel is opaque.
    alpha: Option<Vec<u8>>,
    /// The least and greatest alpha byte, computed once.
    alpha_range: std::sync::OnceLock<(u8, u8)>,
    /// [`TextureImage::mean`], computed once (an image shared by many primitives without
    /// texture coordinates is averaged for each of them).
    mean: std::sync::OnceLock<Vec3>,
}

/// Equal when name, size and texels are (whether the mean is cached or not).
impl PartialEq for TextureImage {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.width == other.width
            && self.height == other.height
            && self.texels == other.texels
            && self.alpha == other.alpha
    }
}

impl std::fmt::Debug for TextureImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "TextureImage({} {}x{})",
            self.name, self.width, self.height
        )
    }
}

/// The sRGB decode of every 8-bit value.
fn srgb_lut() -> &'static [f32; 256] {
    static LUT: OnceLock<[f32; 256]> = OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// The sRGB transfer function, decoded (`c` in [0, 1]).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Largest texture width or height decoded (larger ones are refused when loading).
pub const MAX_TEXTURE_SIZE: u32 = 8192;

/// Most texels all the textures of one file may decode to together (two 8192 x 8192
/// images, 384 MiB as 8-bit RGB): textures past it are refused (the reader warns and uses
/// the factor alone), so a small file naming many huge images stays bounded.
pub const MAX_FILE_TEXELS: u64 = 2 * (MAX_TEXTURE_SIZE as u64) * (MAX_TEXTURE_SIZE as u64);

/// What the images of one file may still decode to, in texels ([`MAX_FILE_TEXELS`] at
/// first), shared by a glTF's textures and an OBJ's maps: checked from an image's header
/// before it is decoded, taken once it is.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TexelBudget {
    left: u64,
}

impl Default for TexelBudget {
    fn default() -> Self {
        TexelBudget {
            left: MAX_FILE_TEXELS,
        }
    }
}

impl TexelBudget {
    /// Whether an image of `w x h` texels fits what is left; why not if it does not.
    pub(crate) fn check(&self, (w, h): (u32, u32)) -> Result<(), String> {
        let texels = u64::from(w) * u64::from(h);
        if texels > self.left {
            return Err(format!(
                "its {w} x {h} texels pass what is left ({}) of the {MAX_FILE_TEXELS} texels all textures of a file may decode to",
                self.left
            ));
        }
        Ok(())
    }

    /// Take a decoded image's texels.
    pub(crate) fn take(&mut self, image: &TextureImage) {
        let texels = u64::from(image.width()) * u64::from(image.height());
        self.left = self.left.saturating_sub(texels);
    }
}

/// Which channel of an image a scalar map reads (see [`TextureImage::decode_scalar`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ScalarChannel {
    /// The alpha channel when the image has one, else the luminance.
    Auto,
    /// The alpha channel (an image without one is opaque: 255).
    Alpha,
    /// The luminance (the `image` crate's, of the stored sRGB values).
    Luminance,
    /// Red (0), green (1) or blue (2).
    Rgb(usize),
}

/// Decode a PNG or JPEG file's bytes, at most `MAX_TEXTURE_SIZE` a side and 256 MiB decoded
/// (the header's size is checked before anything is allocated).
fn decode_limited(bytes: &[u8]) -> Result<image::DynamicImage, String> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIZE);
    limits.max_image_height = Some(MAX_TEXTURE_SIZE);
    limits.max_alloc = Some(256 << 20);
    reader.limits(limits);
    reader.decode().map_err(|e| e.to_string())
}

impl TextureImage {
    /// The width and height a PNG or JPEG file's header declares, read without decoding.
    pub(crate) fn declared_size(bytes: &[u8]) -> Result<(u32, u32), String> {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| e.to_string())?
            .into_dimensions()
            .map_err(|e| e.to_string())
    }

    /// An image of `width x height` sRGB texels, `r, g, b` bytes each (row-major from the
    /// top-left); `None` when the sizes do not match or the image is empty.
    pub fn from_srgb8(
        name: impl Into<String>,
        width: u32,
        height: u32,
        texels: Vec<u8>,
    ) -> Option<TextureImage> {
        (width > 0 && height > 0 && texels.len() as u64 == 3 * u64::from(width) * u64::from(height))
            .then(|| TextureImage {
                name: name.into(),
                width,
                height,
                texels,
                alpha: None,
                alpha_range: std::sync::OnceLock::new(),
                mean: std::sync::OnceLock::new(),
            })
    }

    /// This image with alpha bytes `alpha` (one a texel, row-major); `None` when the count
    /// does not match.
    pub fn with_alpha(mut self, alpha: Vec<u8>) -> Option<TextureImage> {
        (alpha.len() as u64 == u64::from(self.width) * u64::from(self.height)).then(|| {
            self.alpha = Some(alpha);
            self.alpha_range = std::sync::OnceLock::new();
            self
        })
    }
    /// Decode a PNG or JPEG file's bytes (sRGB) as `name`. A small file can decode huge (a
    /// 16000 x 16000 1-bit PNG is 31 KB): the size the header declares is checked before
    /// anything is allocated, at most `MAX_TEXTURE_SIZE` (8192) a side and 256 MiB decoded.
    pub fn decode(bytes: &[u8], name: String) -> Result<TextureImage, String> {
        TextureImage::decode_with(bytes, name, false)
    }

    /// [`TextureImage::decode`], keeping the alpha channel too when `keep_alpha` is set
    /// and the image has one.
    pub fn decode_with(
        bytes: &[u8],
        name: String,
        keep_alpha: bool,
    ) -> Result<TextureImage, String> {
        let img = decode_limited(bytes)?;
        let (w, h) = (img.width(), img.height());
        let alpha = (keep_alpha && img.color().has_alpha()).then(|| {
            let a = img.to_luma_alpha8().into_raw();
            a.chunks_exact(2).map(|p| p[1]).collect::<Vec<u8>>()
        });
        let rgb = img.into_rgb8().into_raw();
        let image = TextureImage::from_srgb8(name, w, h, rgb)
            .ok_or_else(|| "the image is empty".to_string())?;
        match alpha {
            Some(a) => image
                .with_alpha(a)
                .ok_or_else(|| "bad alpha plane".to_string()),
            None => Ok(image),
        }
    }

    /// A scalar map (an OBJ `map_d`) from a PNG or JPEG file's bytes (limits as
    /// [`TextureImage::decode`]): its alpha plane is `channel` of the image, read as the
    /// stored 8-bit value over 255 (no sRGB decode), and its colour is that value as grey.
    pub(crate) fn decode_scalar(
        bytes: &[u8],
        name: String,
        channel: ScalarChannel,
    ) -> Result<TextureImage, String> {
        let img = decode_limited(bytes)?;
        let (w, h) = (img.width(), img.height());
        let channel = match channel {
            ScalarChannel::Auto if img.color().has_alpha() => ScalarChannel::Alpha,
            ScalarChannel::Auto => ScalarChannel::Luminance,
            c => c,
        };
        let values: Vec<u8> = match channel {
            ScalarChannel::Alpha => img.to_luma_alpha8().pixels().map(|p| p[1]).collect(),
            ScalarChannel::Luminance | ScalarChannel::Auto => img.to_luma8().into_raw(),
            ScalarChannel::Rgb(k) => img.to_rgb8().pixels().map(|p| p[k.min(2)]).collect(),
        };
        let grey = values.iter().flat_map(|&v| [v; 3]).collect();
        TextureImage::from_srgb8(name, w, h, grey)
            .and_then(|i| i.with_alpha(values))
            .ok_or_else(|| "the image is empty".to_string())
    }
    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Bytes held by the texels (and the alpha plane, if kept).
    pub fn bytes(&self) -> usize {
        self.texels.len() + self.alpha.as_ref().map_or(0, Vec::len)
    }
    /// Whether an alpha plane is kept (see [`TextureImage::decode_with`]).
    pub fn has_alpha(&self) -> bool {
        self.alpha.is_some()
    }
    /// Alpha of texel `(x, y)` (in range), in [0, 1]; 1 without an alpha plane.
    #[inline]
    pub fn texel_alpha(&self, x: u32, y: u32) -> f32 {
        match &self.alpha {
            Some(a) => f32::from(a[y as usize * self.width as usize + x as usize]) / 255.0,
            None => 1.0,
        }
    }
    /// The least and greatest texel alpha, in [0, 1] (computed on the first call).
    pub fn alpha_range(&self) -> (f32, f32) {
        let (lo, hi) = *self.alpha_range.get_or_init(|| match &self.alpha {
            Some(a) => a
                .iter()
                .fold((u8::MAX, u8::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x))),
            None => (u8::MAX, u8::MAX),
        });
        (f32::from(lo) / 255.0, f32::from(hi) / 255.0)
    }
    /// Linear RGB of texel `(x, y)` (in range).
    #[inline]
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        let lut = srgb_lut();
        let i = 3 * (y as usize * self.width as usize + x as usize);
        let t = &self.texels[i..i + 3];
        Vec3::new(lut[t[0] as usize], lut[t[1] as usize], lut[t[2] as usize])
    }
    /// Mean linear RGB over every texel (computed on the first call, then kept).
    pub fn mean(&self) -> Vec3 {
        *self.mean.get_or_init(|| self.compute_mean())
    }

    fn compute_mean(&self) -> Vec3 {
        let lut = srgb_lut();
        let mut sum = [0f64; 3];
        for t in self.texels.chunks_exact(3) {
            for k in 0..3 {
                sum[k] += f64::from(lut[t[k] as usize]);
            }
        }
        let n = (self.texels.len() / 3).max(1) as f64;
        Vec3::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    }
}

/// How texture coordinates outside [0, 1] are mapped (glTF sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles (glTF's default, 10497).
    #[default]
    Repeat,
    /// The edge texels extend (33071).
    ClampToEdge,
    /// The image tiles, every other copy mirrored (33648).
    MirroredRepeat,
}

impl Wrap {
    /// Texel index `i` wrapped into `0..n`.
    #[inline]
    fn index(self, i: i64, n: u32) -> u32 {
        let n = i64::from(n);
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        }) as u32
    }
}

/// Texel filter (glTF sampler `magFilter`; minification is handled by averaging over the
/// footprint, see the `shrad` crate).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// The nearest texel (9728).
    Nearest,
    /// Bilinear between the four nearest texels (9729, the default).
    #[default]
    Linear,
}

/// `KHR_texture_transform`: `uv' = T(offset) R(rotation) S(scale) uv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    /// Offset (in UV units).
    pub offset: Vec2,
    /// Rotation in radians (the UVs turn counter-clockwise, the image clockwise).
    pub rotation: f32,
    /// Scale.
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform {
            offset: Vec2::ZERO,
            rotation: 0.0,
            scale: Vec2::ONE,
        }
    }
}

impl UvTransform {
    /// The transformed coordinates, as the extension's matrix
    /// `[[c, s, ox], [-s, c, oy]] * diag(sx, sy, 1)` gives them.
    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let s = uv * self.scale;
        let (sin, cos) = self.rotation.sin_cos();
        Vec2::new(cos * s.x + sin * s.y, -sin * s.x + cos * s.y) + self.offset
    }
}

/// A material's use of an image.
#[derive(Clone, Debug)]
pub struct Texture {
    /// The decoded image, shared by every material that uses it.
    pub image: Arc<TextureImage>,
    /// The texture-coordinate set (`TEXCOORD_n`) it reads (after the transform's override).
    pub tex_coord: u32,
    /// Wrap mode along U.
    pub wrap_s: Wrap,
    /// Wrap mode along V.
    pub wrap_t: Wrap,
    /// Magnification filter.
    pub filter: Filter,
    /// `KHR_texture_transform` (identity when absent).
    pub transform: UvTransform,
}

impl PartialEq for Texture {
    fn eq(&self, other: &Self) -> bool {
        (Arc::ptr_eq(&self.image, &other.image) || self.image == other.image)
            && self.tex_coord == other.tex_coord
            && self.wrap_s == other.wrap_s
            && self.wrap_t == other.wrap_t
            && self.filter == other.filter
            && self.transform == other.transform
    }
}

impl Texture {
    /// A texture that reads `image` through set 0 with glTF's default sampler.
    pub fn new(image: Arc<TextureImage>) -> Texture {
        Texture {
            image,
            tex_coord: 0,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            filter: Filter::Linear,
            transform: UvTransform::default(),
        }
    }

    /// Texel-space coordinates of texture coordinates `uv` (transform applied).
    #[inline]
    pub fn texel_coords(&self, uv: Vec2) -> Vec2 {
        let t = self.transform.apply(uv);
        Vec2::new(
            t.x * self.image.width as f32,
            t.y * self.image.height as f32,
        )
    }

    /// Linear RGB at texture coordinates `uv` (transform, wrap and filter applied). Never
    /// panics: a non-finite coordinate reads some texel of the image.
    #[inline]
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        self.filtered(uv, |img, x, y| img.texel(x, y))
    }

    /// Alpha at texture coordinates `uv` (as [`Texture::sample`] samples colour): 1 for an
    /// image without an alpha plane.
    #[inline]
    pub fn sample_alpha(&self, uv: Vec2) -> f32 {
        self.filtered(uv, |img, x, y| Vec3::splat(img.texel_alpha(x, y)))
            .x
    }

    /// The least and greatest texel alpha that a sample anywhere in the texel-space box
    /// `lo..hi` (from [`Texture::texel_coords`]) can be made of, with either filter and
    /// the wrap modes: so every sample of a triangle whose corners lie in the box is
    /// between them. None when the box covers more than `max_texels` texels (or is not
    /// finite).
    pub fn alpha_bounds(&self, lo: Vec2, hi: Vec2, max_texels: u64) -> Option<(f32, f32)> {
        let img = &*self.image;
        if !img.has_alpha() {
            return Some((1.0, 1.0));
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        let (x0, x1) = ((lo.x - 0.5).floor(), (hi.x + 0.5).floor());
        let (y0, y1) = ((lo.y - 0.5).floor(), (hi.y + 0.5).floor());
        let count = (f64::from(x1 - x0) + 1.0) * (f64::from(y1 - y0) + 1.0);
        if count > max_texels as f64 {
            return None;
        }
        let (mut a, mut b) = (1f32, 0f32);
        for y in y0 as i64..=y1 as i64 {
            let y = self.wrap_t.index(y, img.height);
            for x in x0 as i64..=x1 as i64 {
                let t = img.texel_alpha(self.wrap_s.index(x, img.width), y);
                a = a.min(t);
                b = b.max(t);
            }
        }
        Some((a, b))
    }

    /// What `fetch` gives at `uv` through the sampler (transform, wrap, filter).
    #[inline]
    fn filtered(&self, uv: Vec2, fetch: impl Fn(&TextureImage, u32, u32) -> Vec3) -> Vec3 {
        let img = &*self.image;
        let p = self.texel_coords(uv);
        // Far outside any sensible range a coordinate keeps no sub-texel precision anyway.
        let p = p.clamp(Vec2::splat(-1e12), Vec2::splat(1e12));
        match self.filter {
            Filter::Nearest => {
                let x = self.wrap_s.index(p.x.floor() as i64, img.width);
                let y = self.wrap_t.index(p.y.floor() as i64, img.height);
                fetch(img, x, y)
            }
            Filter::Linear => {
                let q = p - Vec2::splat(0.5);
                let (fx, fy) = (q.x.floor(), q.y.floor());
                let (tx, ty) = (q.x - fx, q.y - fy);
                let (ix, iy) = (fx as i64, fy as i64);
                let x0 = self.wrap_s.index(ix, img.width);
                let x1 = self.wrap_s.index(ix + 1, img.width);
                let y0 = self.wrap_t.index(iy, img.height);
                let y1 = self.wrap_t.index(iy + 1, img.height);
                let top = fetch(img, x0, y0).lerp(fetch(img, x1, y0), tx);
                let bottom = fetch(img, x0, y1).lerp(fetch(img, x1, y1), tx);
                top.lerp(bottom, ty)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Arc<TextureImage> {
        // 2 x 2: black, white / white, black.
        let (k, w) = ([0u8; 3], [255u8; 3]);
        let texels = [k, w, w, k].concat();
        Arc::new(TextureImage::from_srgb8("checker", 2, 2, texels).unwrap())
    }

    #[test]
    fn wrap_modes_map_indices() {
        assert_eq!(Wrap::Repeat.index(-1, 4), 3);
        assert_eq!(Wrap::Repeat.index(9, 4), 1);
        assert_eq!(Wrap::ClampToEdge.index(-5, 4), 0);
        assert_eq!(Wrap::ClampToEdge.index(9, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.index(4, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.index(-1, 4), 0);
        assert_eq!(Wrap::MirroredRepeat.index(8, 4), 0);
    }

    #[test]
    fn nearest_samples_texels_and_transform_moves_them() {
        let mut t = Texture::new(checker());
        t.filter = Filter::Nearest;
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), Vec3::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)), Vec3::ONE);
        // REPEAT: u = 1.25 is u = 0.25 again.
        assert_eq!(t.sample(Vec2::new(1.25, 0.25)), Vec3::ZERO);
        // An offset of half the image swaps the squares.
        t.transform.offset = Vec2::new(0.5, 0.0);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), Vec3::ONE);
        // A quarter turn: (u, v) -> (v, -u).
        t.transform = UvTransform {
            rotation: std::f32::consts::FRAC_PI_2,
            ..Default::default()
        };
        let p = t.transform.apply(Vec2::new(1.0, 0.0));
        assert!(p.abs_diff_eq(Vec2::new(0.0, -1.0), 1e-6), "{p}");
        assert!(t.sample(Vec2::new(f32::NAN, f32::INFINITY)).is_finite());
    }

    #[test]
    fn bilinear_interpolates_between_texel_centres() {
        let t = Texture::new(checker());
        // Half-way between a black and a white texel centre.
        let mid = t.sample(Vec2::new(0.5, 0.25));
        assert!((mid.x - 0.5).abs() < 1e-6, "{mid}");
        assert!((checker().mean().x - 0.5).abs() < 1e-6);
    }

    /// A file's images share one budget of texels (a glTF's textures, an OBJ's maps),
    /// checked from each header before it is decoded, taken once it is.
    #[test]
    fn a_files_images_share_one_budget_of_texels() {
        let mut budget = TexelBudget { left: 20 };
        let image = TextureImage::from_srgb8("a", 4, 4, vec![0; 48]).unwrap();
        budget.check((4, 4)).unwrap();
        budget.take(&image);
        let e = budget.check((4, 4)).unwrap_err();
        assert!(e.contains("4 x 4 texels pass what is left (4)"), "{e}");
    }
}
