//! Materials and their textures: the base colour and emission factors, the images (from a
//! buffer view, a data URI or a file, each decoded once) with their samplers and
//! `KHR_texture_transform`; and what `alphaMode` makes of them (see [`cut_away`]).
//!
//! shrad's patches are opaque: they cannot have holes nor let light through. So a material
//! is either opaque or, when nothing of it can be seen, cut away: a MASK material whose base
//! colour alpha factor is below its `alphaCutoff`, or a BLEND one whose alpha factor is 0.
//! (Base colour alpha is the factor times the texture's and `COLOR_0`'s alphas, each at most
//! 1: a factor below the cutoff cuts every texel away, textured or not.) A MASK material
//! with a base colour texture is cut by its texels' alpha in geometry, primitive by
//! primitive (`cutout`); its image is decoded with an alpha plane. Every other BLEND
//! material is treated as opaque, with a warning once per material (a viewer shows it
//! transparent).

use glam::Vec3;

use super::{buffers::read_uri, walk::Walk};
use crate::{Filter, Material, Texture, TextureImage, UvTransform, Wrap};

/// A material's base colour factor (RGBA) and texture: the metallic-roughness model's, or,
/// when the material has `KHR_materials_pbrSpecularGlossiness` (archived, still in older
/// files), its `diffuseFactor` and `diffuseTexture`, which the extension says a client that
/// reads it uses instead (its specular and glossiness change nothing diffuse).
pub(super) fn base_color<'a>(
    m: &gltf::Material<'a>,
) -> ([f32; 4], Option<gltf::texture::Info<'a>>) {
    match m.pbr_specular_glossiness() {
        Some(sg) => (sg.diffuse_factor(), sg.diffuse_texture()),
        None => {
            let pbr = m.pbr_metallic_roughness();
            (pbr.base_color_factor(), pbr.base_color_texture())
        }
    }
}

impl Walk<'_> {
    /// The shrad material of a glTF material (converted once per material). A reflectance
    /// of exactly 1 (allowed by glTF, but it does not conserve energy) becomes 0.999 with a
    /// warning; factors outside [0, 1] were refused by [`super::validate::check_json`].
    pub(super) fn material(&mut self, m: &gltf::Material) -> Material {
        if let Some(done) = self.materials.get(&m.index()) {
            return done.clone();
        }
        let who = match (m.index(), m.name()) {
            (Some(i), Some(n)) => format!("materials[{i}] '{n}'"),
            (Some(i), None) => format!("materials[{i}]"),
            (None, _) => "the default material (a primitive without one)".to_string(),
        };
        let (f, base_texture) = base_color(m);
        let mut reflectance = Vec3::new(f[0], f[1], f[2]);
        let base_color_texture =
            base_texture.and_then(|info| self.texture(&who, "base colour", &info));
        if reflectance.max_element() >= 1.0 {
            let clamped = reflectance.min(Vec3::splat(crate::MAX_REFLECTANCE));
            self.scene.warnings.push(format!(
                "{who}: reflectance {reflectance} clamped to {clamped} (a reflectance of 1 does not conserve energy; it must be < 1)"
            ));
            reflectance = clamped;
        }
        let e = m.emissive_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let emissive_texture = m
            .emissive_texture()
            .and_then(|info| self.texture(&who, "emissive", &info));
        self.warn_alpha(m, &who);
        let material = Material {
            reflectance,
            emitted_radiance: Vec3::from(e) * strength,
            double_sided: m.double_sided(),
            base_color_texture,
            emissive_texture,
        };
        self.materials.insert(m.index(), material.clone());
        material
    }

    /// Warn (once per material: [`Walk::material`] converts each once) about an alpha mode
    /// that shrad draws opaque though a viewer does not. A material [`cut_away`] entirely
    /// never gets here: its primitives are skipped.
    fn warn_alpha(&mut self, m: &gltf::Material, who: &str) {
        let (factor, texture) = base_color(m);
        let (alpha, textured) = (factor[3], texture.is_some());
        let why = match m.alpha_mode() {
            // A textured MASK is cut by its texture in geometry (`cutout`), which warns.
            gltf::material::AlphaMode::Opaque | gltf::material::AlphaMode::Mask => return,
            gltf::material::AlphaMode::Blend => format!(
                "alphaMode BLEND (base colour alpha {alpha}{}): transparency is not represented, the surface is treated as opaque",
                if textured { " times the texture's" } else { "" }
            ),
        };
        self.scene.warnings.push(format!("{who}: {why}"));
    }

    /// The texture of a material's texture info: its image decoded once (shared by every
    /// material that uses it), its sampler and `KHR_texture_transform`. `None` (with a
    /// warning) when the image cannot be loaded.
    fn texture(&mut self, who: &str, what: &str, info: &gltf::texture::Info) -> Option<Texture> {
        let texture = info.texture().index();
        // The texture's source, from the raw JSON: the gltf crate's `source()` panics when
        // an extension (not read by shrad) provides the image instead.
        let Some(image) = self.json["textures"][texture]["source"]
            .as_u64()
            .map(|i| i as usize)
        else {
            self.scene.warnings.push(format!(
                "{who}: {what} texture {texture} has no image shrad can read; using the factor alone"
            ));
            return None;
        };
        // Images are shared by their source: seven images of one buffer view or URI decode once.
        let key = self.image_source(image);
        let decoded = match self.textures.get(&key) {
            Some(d) => d.clone(),
            None => {
                let d = match self.texture_image(image) {
                    Ok(d) => Some(std::sync::Arc::new(d)),
                    Err(e) => {
                        let name = self.image_label(image);
                        self.scene.warnings.push(format!(
                            "{who}: {what} {name} cannot be loaded ({e}); using the factor alone"
                        ));
                        None
                    }
                };
                self.textures.insert(key, d.clone());
                d
            }
        }?;
        let sampler = info.texture().sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let mut t = Texture::new(decoded);
        t.tex_coord = info.tex_coord();
        t.wrap_s = wrap(sampler.wrap_s());
        t.wrap_t = wrap(sampler.wrap_t());
        if sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest) {
            t.filter = Filter::Nearest;
        }
        if let Some(x) = info.texture_transform() {
            t.transform = UvTransform {
                offset: x.offset().into(),
                rotation: x.rotation(),
                scale: x.scale().into(),
            };
            if let Some(k) = x.tex_coord() {
                t.tex_coord = k;
            }
        }
        Some(t)
    }

    /// The sources of the images that `alphaMode: MASK` materials use as base colour: those
    /// are decoded with their alpha plane (the others without: it would cost a byte a texel
    /// for nothing).
    pub(super) fn mask_sources(&self) -> std::collections::HashSet<ImageSource> {
        self.doc
            .materials()
            .filter(|m| m.alpha_mode() == gltf::material::AlphaMode::Mask)
            .filter_map(|m| base_color(&m).1)
            .filter_map(|info| self.json["textures"][info.texture().index()]["source"].as_u64())
            .map(|i| self.image_source(i as usize))
            .collect()
    }

    /// `image N 'name'` (or its URI) for messages.
    fn image_label(&self, index: usize) -> String {
        let json = self.doc.as_json().images.get(index);
        match json.and_then(|j| j.name.clone().or_else(|| j.uri.clone())) {
            Some(n) if !n.starts_with("data:") => format!("image {index} '{n}'"),
            _ => format!("image {index}"),
        }
    }

    /// What image `index` is read from (its buffer view, else its URI), so images that
    /// share one are decoded once.
    fn image_source(&self, index: usize) -> ImageSource {
        match self.doc.as_json().images.get(index) {
            Some(j) if j.buffer_view.is_some() => {
                ImageSource::View(j.buffer_view.map_or(0, |v| v.value()))
            }
            Some(j) if j.uri.is_some() => ImageSource::Uri(j.uri.clone().unwrap_or_default()),
            _ => ImageSource::Image(index),
        }
    }

    /// Image `index`, decoded to 8-bit sRGB RGB (see [`TextureImage`]), within what is left
    /// of the file's texel budget ([`crate::texture::MAX_FILE_TEXELS`]), which it spends.
    fn texture_image(&mut self, index: usize) -> Result<TextureImage, String> {
        let json = self
            .doc
            .as_json()
            .images
            .get(index)
            .ok_or_else(|| format!("no image {index}"))?;
        let bytes: Vec<u8> = if let Some(view) = &json.buffer_view {
            let view = self
                .doc
                .views()
                .nth(view.value())
                .ok_or("image buffer view out of range")?;
            let data = self
                .buffers
                .get(view.buffer().index())
                .ok_or("buffer out of range")?;
            data.0
                .get(view.offset()..view.offset() + view.length())
                .ok_or("image buffer view outside its buffer")?
                .to_vec()
        } else if let Some(uri) = &json.uri {
            read_uri(self.base, uri)?
        } else {
            return Err("image has neither uri nor bufferView".into());
        };
        // A KTX2 / Basis Universal image (KHR_texture_basisu) is transcoded to RGBA.
        let ktx2 = match bytes.starts_with(crate::ktx2::KTX2_MAGIC) {
            true => Some(crate::ktx2::Ktx2::open(&bytes)?),
            false => None,
        };
        let (w, h) = match &ktx2 {
            Some(k) => k.size,
            None => TextureImage::declared_size(&bytes)?,
        };
        self.texels.check((w, h))?;
        let keep_alpha = self.mask_images.contains(&self.image_source(index));
        let image = match ktx2 {
            Some(k) => k.decode(self.image_label(index), keep_alpha)?,
            None => TextureImage::decode_with(&bytes, self.image_label(index), keep_alpha)?,
        };
        self.texels.take(&image);
        Ok(image)
    }
}

/// Why nothing of material `m` is seen (so a primitive drawn with it neither reflects nor
/// blocks light, and is left out), if so. glTF 2.0, "Alpha Coverage": the base colour's alpha
/// is the factor's times the texture's (and `COLOR_0`'s), each in [0, 1], so the factor
/// bounds it from above whatever the texture:
/// - MASK: a fragment is drawn when its alpha is at least `alphaCutoff` (default 0.5); a
///   factor below the cutoff cuts the whole surface away.
/// - BLEND: a fragment's alpha is its coverage; a factor of 0 covers nothing, in every
///   viewer. (Any other BLEND is treated as opaque: a patch cannot let part of the light
///   through, and a surface a viewer shows should not vanish.)
pub(super) fn cut_away(m: &gltf::Material) -> Option<String> {
    let alpha = base_color(m).0[3];
    let who = match (m.index(), m.name()) {
        (Some(i), Some(n)) => format!("materials[{i}] '{n}'"),
        (Some(i), None) => format!("materials[{i}]"),
        (None, _) => return None,
    };
    match m.alpha_mode() {
        gltf::material::AlphaMode::Mask => {
            let cutoff = m.alpha_cutoff().unwrap_or(0.5);
            (alpha < cutoff).then(|| {
                format!(
                    "{who} is alphaMode MASK with a base colour alpha {alpha} below its alphaCutoff {cutoff}: entirely cut away"
                )
            })
        }
        gltf::material::AlphaMode::Blend => (alpha == 0.0).then(|| {
            format!("{who} is alphaMode BLEND with a base colour alpha of 0: entirely transparent")
        }),
        gltf::material::AlphaMode::Opaque => None,
    }
}

/// Where an image's bytes come from (the key of the reader's decoded images).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub(super) enum ImageSource {
    /// A buffer view.
    View(usize),
    /// A URI (data or file).
    Uri(String),
    /// Neither (cannot be loaded): by image index.
    Image(usize),
}
