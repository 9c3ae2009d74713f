//! KTX2 / Basis Universal images (glTF's `KHR_texture_basisu`: ETC1S or UASTC, BasisLZ or
//! zstd supercompression, what gltfpack's `-tc` and glTF-Transform's `etc1s` / `uastc`
//! write), transcoded to RGBA by the pure-Rust `basisu` crate (a port of Binomial's
//! reference transcoder; its zstd is ruzstd's), after shrad has checked the header.

use crate::texture::{TextureImage, MAX_TEXTURE_SIZE};

/// The KTX2 file identifier (its first 12 bytes).
pub(crate) const KTX2_MAGIC: &[u8] = b"\xABKTX 20\xBB\r\n\x1A\n";

/// A KTX2 / Basis Universal texture (glTF's `KHR_texture_basisu`: ETC1S or UASTC, with
/// BasisLZ or zstd supercompression), opened by the pure-Rust `basisu` transcoder. Its base
/// level's size, read from the container, is checked before anything is transcoded.
pub(crate) struct Ktx2<'a> {
    transcoder: basisu::Transcoder<'a>,
    /// The base level's width and height.
    pub size: (u32, u32),
}

/// The KTX2 header and level index checked against the file before the transcoder sees
/// them (KTX 2.0, "File Structure"; glTF's KHR_texture_basisu: one 2D image, no array, no
/// cube map): the sizes at most `MAX_TEXTURE_SIZE` a side, a full mip chain at most, and
/// every offset and length within the file, each level's uncompressed length at most what
/// its blocks can take. basisu 0.1 trusts these fields: a flipped byte of a level's
/// uncompressed length made it ask for 700 GB, which aborts the process (no guard catches
/// an allocation failure).
fn check_ktx2_header(b: &[u8]) -> Result<(), String> {
    let u32_at = |o: usize| {
        b.get(o..o + 4)
            .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    };
    let u64_at = |o: usize| {
        b.get(o..o + 8)
            .map(|s| u64::from_le_bytes([s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7]]))
    };
    let short = || {
        "a KTX2 / Basis Universal file cut short (its header or level index is missing)".to_string()
    };
    let field = |o: usize| u32_at(o).ok_or_else(short);
    let (w, h, depth) = (field(20)?, field(24)?, field(28)?);
    let (layers, faces, levels) = (field(32)?, field(36)?, field(40)?.max(1));
    if w == 0 || h == 0 || w > MAX_TEXTURE_SIZE || h > MAX_TEXTURE_SIZE {
        return Err(format!(
            "its {w} x {h} texels are not within 1 and {MAX_TEXTURE_SIZE} a side"
        ));
    }
    if depth > 1 || layers > 1 || faces != 1 {
        return Err(format!(
            "a KTX2 image of depth {depth}, {layers} layers and {faces} faces (a glTF texture is one 2D image)"
        ));
    }
    let chain = 32 - w.max(h).leading_zeros();
    if levels > chain {
        return Err(format!(
            "{levels} mip levels for a {w} x {h} image (at most {chain})"
        ));
    }
    let len = b.len() as u64;
    let within = |offset: u64, length: u64| offset.checked_add(length).is_some_and(|e| e <= len);
    let ranges = [
        (u64::from(field(48)?), u64::from(field(52)?)),
        (u64::from(field(56)?), u64::from(field(60)?)),
        (u64_at(64).ok_or_else(short)?, u64_at(72).ok_or_else(short)?),
    ];
    if !ranges.iter().all(|&(o, l)| within(o, l)) {
        return Err("a KTX2 data block lies outside the file".into());
    }
    for level in 0..levels as usize {
        let at = 80 + 24 * level;
        let (offset, length) = (
            u64_at(at).ok_or_else(short)?,
            u64_at(at + 8).ok_or_else(short)?,
        );
        let uncompressed = u64_at(at + 16).ok_or_else(short)?;
        let blocks =
            u64::from((w >> level).max(1).div_ceil(4)) * u64::from((h >> level).max(1).div_ceil(4));
        if !within(offset, length) || uncompressed > 16 * blocks {
            return Err(format!(
                "KTX2 level {level}: its data ({length} bytes at {offset}, {uncompressed} uncompressed) does not fit the file or the level"
            ));
        }
    }
    Ok(())
}

impl<'a> Ktx2<'a> {
    /// Open `bytes` (a `.ktx2` file), at most `MAX_TEXTURE_SIZE` a side.
    pub(crate) fn open(bytes: &'a [u8]) -> Result<Ktx2<'a>, String> {
        check_ktx2_header(bytes)?;
        let bad = |e: basisu::Error| format!("not a readable KTX2 / Basis Universal image ({e:?})");
        // basisu 0.1 is young: a corrupt container must be an error, never a panic.
        let opened = std::panic::catch_unwind(|| -> Result<_, String> {
            let transcoder = basisu::Transcoder::new(bytes).map_err(bad)?;
            let info = transcoder.image_level_info(0).map_err(bad)?;
            Ok((transcoder, (info.width, info.height)))
        })
        .map_err(|_| "a malformed KTX2 image (the transcoder gave up on it)".to_string())?;
        let (transcoder, (w, h)) = opened?;
        if w == 0 || h == 0 || w > MAX_TEXTURE_SIZE || h > MAX_TEXTURE_SIZE {
            return Err(format!(
                "its {w} x {h} texels pass the {MAX_TEXTURE_SIZE} a side shrad decodes"
            ));
        }
        Ok(Ktx2 {
            transcoder,
            size: (w, h),
        })
    }

    /// The base level (the first layer and face) as an sRGB image named `name`, with its
    /// alpha when `keep_alpha` is set and the texture has one. Base colour textures are
    /// sRGB (glTF 2.0), as PNG and JPEG ones are read.
    pub(crate) fn decode(self, name: String, keep_alpha: bool) -> Result<TextureImage, String> {
        let (w, h) = self.size;
        let flags = basisu::DecodeFlags::NONE;
        let rgba = std::panic::catch_unwind(|| {
            self.transcoder
                .transcode_image(0, 0, 0, basisu::TargetFormat::Rgba32, flags)
        })
        .map_err(|_| "a malformed KTX2 image (the transcoder gave up on it)".to_string())?
        .map_err(|e| format!("cannot transcode the KTX2 image ({e:?})"))?;
        if rgba.len() as u64 != 4 * u64::from(w) * u64::from(h) {
            return Err(format!(
                "the KTX2 image transcoded to {} bytes for {w} x {h} texels",
                rgba.len()
            ));
        }
        let rgb = rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        let image = TextureImage::from_srgb8(name, w, h, rgb)
            .ok_or_else(|| "the image is empty".to_string())?;
        if keep_alpha && self.transcoder.has_alpha() {
            let alpha = rgba.chunks_exact(4).map(|p| p[3]).collect();
            return image
                .with_alpha(alpha)
                .ok_or_else(|| "bad alpha plane".to_string());
        }
        Ok(image)
    }
}
