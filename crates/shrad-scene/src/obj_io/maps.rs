//! An MTL material's texture maps and transparency.
//!
//! **Map statements** (`map_Kd`, `map_d`): options come before the file name
//! (`map_d -clamp on -imfchan m leaf.png`). Read: `-clamp on` (the edge texels extend instead
//! of the image tiling), `-o u v` and `-s u v` (offset and scale of the texture
//! coordinates, in OBJ's v-up space; a third value is ignored) and, for `map_d`, `-imfchan`.
//! Other options of the MTL format (`-bm`, `-mm`, `-t`, `-blendu`, ...) are skipped with
//! their values; an unknown one is skipped with the numbers and `on` / `off` after it. What
//! follows is the file name (it may hold spaces), relative to the MTL file that names it.
//!
//! **Alpha** (`map_d`): shrad's surfaces are opaque, so a `map_d` (a leaf card, a fence) is
//! cut in geometry by [`crate::cutout`] with a cutoff of 0.5, as a glTF `alphaMode: MASK`
//! texture is: the parts of each triangle whose alpha is at least 0.5 are kept. The alpha
//! is the image's alpha channel when it has one (Blender writes `map_d` as the RGBA image
//! whose alpha its material uses), else its luminance (the MTL format's scalar map: a
//! greyscale image's value), as the 8-bit value over 255; `-imfchan r|g|b|l|m` chooses the
//! red, green, blue, luminance or alpha ("matte") channel instead.
//!
//! **Dissolve** (`d`, or `Tr` = 1 − `d` when there is no `d`): `d 0` (nothing of the
//! material is seen) leaves its objects out, with a warning; a partial dissolve (0 < `d`
//! < 1, a glass pane) is drawn opaque, with one warning per material (transparency is not
//! represented), as glTF's `alphaMode: BLEND` is. A material that names a `map_d` goes by
//! the map alone, its `d` unread (Blender 2.7x wrote `d 0` beside its alpha maps, whose
//! leaves would all have been left out), whether the map loads or not.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec2;

use crate::cutout::{cut, Mask, MAX_ADDED};
use crate::texture::{ScalarChannel, TexelBudget};
use crate::{Object, Texture, TextureImage, UvTransform, Wrap};

/// The cutoff `map_d`'s alpha is cut at (glTF's default `alphaCutoff`, the usual one for
/// masked alpha).
pub(super) const MAP_D_CUTOFF: f32 = 0.5;

/// A map statement's file and the options shrad reads (see the module's documentation).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct MapSpec {
    pub file: String,
    pub clamp: bool,
    pub offset: Vec2,
    pub scale: Vec2,
    /// `-imfchan`'s letter, if given.
    pub channel: Option<char>,
}

/// Options of the MTL format and how many values each takes (at most; numbers).
const OPTIONS: [(&str, usize); 13] = [
    ("-blendu", 1),
    ("-blendv", 1),
    ("-bm", 1),
    ("-boost", 1),
    ("-cc", 1),
    ("-clamp", 1),
    ("-imfchan", 1),
    ("-mm", 2),
    ("-o", 3),
    ("-s", 3),
    ("-t", 3),
    ("-texres", 1),
    ("-type", 1),
];

/// The file and options of a map statement's argument (what follows `map_Kd`).
pub(super) fn parse_map(arg: &str) -> MapSpec {
    let words: Vec<&str> = arg.split_whitespace().collect();
    let mut spec = MapSpec {
        file: String::new(),
        clamp: false,
        offset: Vec2::ZERO,
        scale: Vec2::ONE,
        channel: None,
    };
    let is_number = |w: &str| w.parse::<f32>().is_ok();
    let mut i = 0;
    while i < words.len() && words[i].starts_with('-') && !is_number(words[i]) {
        let name = words[i];
        i += 1;
        let values = match OPTIONS.iter().find(|(o, _)| *o == name) {
            Some(&(_, 1)) if !matches!(name, "-bm" | "-boost" | "-texres") => {
                // A word value (`on`, `m`, `sphere`), taken when one is left for the file.
                usize::from(i + 1 < words.len())
            }
            Some(&(_, n)) => words[i..]
                .iter()
                .take(n)
                .take_while(|w| is_number(w))
                .count(),
            None => words[i..]
                .iter()
                .take_while(|w| is_number(w) || matches!(**w, "on" | "off"))
                .count(),
        };
        let v = &words[i..i + values];
        let num = |k: usize, or: f32| v.get(k).and_then(|w| w.parse().ok()).unwrap_or(or);
        match name {
            "-clamp" => spec.clamp = v.first() == Some(&"on"),
            "-imfchan" => spec.channel = v.first().and_then(|w| w.chars().next()),
            "-o" => spec.offset = Vec2::new(num(0, 0.0), num(1, 0.0)),
            "-s" => spec.scale = Vec2::new(num(0, 1.0), num(1, 1.0)),
            _ => {}
        }
        i += values;
    }
    spec.file = if i < words.len() {
        words[i..].join(" ")
    } else {
        words.last().copied().unwrap_or("").to_string()
    };
    spec
}

/// What an image is decoded as.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Kind {
    /// A colour map (`map_Kd`).
    Colour,
    /// A scalar map's channel (`map_d`), as the image's alpha plane.
    Scalar(char),
}

/// The map images, each decoded once per kind. Their paths are relative to the MTL file that
/// names them (tobj does not say which one: the first library directory holding the file
/// wins).
pub(super) struct Maps<'a> {
    pub obj: &'a Path,
    pub lib_dirs: Vec<PathBuf>,
    images: HashMap<(String, Kind), Option<Arc<TextureImage>>>,
    /// What the file's images may still decode to (as a glTF's).
    texels: TexelBudget,
}

impl<'a> Maps<'a> {
    pub fn new(obj: &'a Path, lib_dirs: Vec<PathBuf>) -> Maps<'a> {
        Maps {
            obj,
            lib_dirs,
            images: HashMap::new(),
            texels: TexelBudget::default(),
        }
    }

    /// The `map_Kd` texture of argument `arg`, or `None` with a warning when its image
    /// cannot be loaded.
    pub fn colour(&mut self, arg: &str, warnings: &mut Vec<String>) -> Option<Texture> {
        let spec = parse_map(arg);
        let image = self.image(
            &spec.file,
            Kind::Colour,
            warnings,
            "map_Kd",
            "using Kd alone",
        )?;
        Some(texture(&spec, image))
    }

    /// The `map_d` texture of argument `arg`, its chosen channel as the image's alpha plane
    /// (see the module's documentation), or `None` with a warning when its image cannot be
    /// loaded.
    pub fn alpha(&mut self, arg: &str, warnings: &mut Vec<String>) -> Option<Texture> {
        let spec = parse_map(arg);
        let channel = match spec.channel {
            Some(c @ ('r' | 'g' | 'b' | 'l' | 'm')) => c,
            Some(c) => {
                warnings.push(format!(
                    "{}: map_d '{}': -imfchan {c} is not read; using the alpha channel, else the luminance",
                    self.obj.display(),
                    spec.file
                ));
                'a'
            }
            None => 'a',
        };
        let what = "the material stays opaque";
        let image = self.image(&spec.file, Kind::Scalar(channel), warnings, "map_d", what)?;
        Some(texture(&spec, image))
    }

    /// Image `file` decoded as `kind` (once), or `None` with a warning that `statement`
    /// names a file that cannot be loaded, so `fallback`.
    fn image(
        &mut self,
        file: &str,
        kind: Kind,
        warnings: &mut Vec<String>,
        statement: &str,
        fallback: &str,
    ) -> Option<Arc<TextureImage>> {
        let (lib_dirs, obj) = (&self.lib_dirs, self.obj);
        let texels = &mut self.texels;
        self.images
            .entry((file.to_string(), kind))
            .or_insert_with(|| {
                // The first place the name exists; a device or a folder there is named as
                // such (reading /dev/zero would never end), not "not found".
                let found = lib_dirs.iter().map(|d| d.join(file)).find(|p| p.exists());
                let r = match &found {
                    None => Err("file not found".to_string()),
                    Some(p) if !p.is_file() => Err(format!(
                        "'{}' is not a regular file (a folder or a device)",
                        p.display()
                    )),
                    Some(p) => std::fs::read(p).map_err(|e| e.to_string()).and_then(|b| {
                        texels.check(TextureImage::declared_size(&b)?)?;
                        let name = file.to_string();
                        let image = match kind {
                            Kind::Colour => TextureImage::decode(&b, name),
                            Kind::Scalar(c) => TextureImage::decode_scalar(&b, name, channel(c)),
                        }?;
                        texels.take(&image);
                        Ok(image)
                    }),
                };
                match r {
                    Ok(img) => Some(Arc::new(img)),
                    Err(e) => {
                        warnings.push(format!(
                            "{}: {statement} '{file}' cannot be loaded ({e}); {fallback}",
                            obj.display()
                        ));
                        None
                    }
                }
            })
            .clone()
    }
}

/// The channel of `-imfchan` letter `c` (`a`: none given).
fn channel(c: char) -> ScalarChannel {
    match c {
        'r' => ScalarChannel::Rgb(0),
        'g' => ScalarChannel::Rgb(1),
        'b' => ScalarChannel::Rgb(2),
        'l' => ScalarChannel::Luminance,
        'm' => ScalarChannel::Alpha,
        _ => ScalarChannel::Auto,
    }
}

/// `image` read as `spec` says: through set 0 (OBJ's `vt`, stored with v flipped to the
/// image's downward v), tiling unless `-clamp on`, bilinear, with `-o` / `-s` as a texture
/// transform.
fn texture(spec: &MapSpec, image: Arc<TextureImage>) -> Texture {
    let mut t = Texture::new(image);
    if spec.clamp {
        (t.wrap_s, t.wrap_t) = (Wrap::ClampToEdge, Wrap::ClampToEdge);
    }
    // OBJ's (u, v) maps to (o.u + s.u u, o.v + s.v v); shrad's y = 1 - v, so the image's
    // y' = 1 - (o.v + s.v (1 - y)) = (1 - o.v - s.v) + s.v y.
    let (o, s) = (spec.offset, spec.scale);
    t.transform = UvTransform {
        offset: Vec2::new(o.x, 1.0 - o.y - s.y),
        rotation: 0.0,
        scale: s,
    };
    t
}

/// A material's transparency: its `map_d` texture and dissolve.
#[derive(Clone, Debug, Default)]
pub(super) struct Alpha {
    /// The `map_d` texture (loaded).
    pub map: Option<Texture>,
    /// Its dissolve (None: 1).
    pub dissolve: Option<Dissolve>,
}

/// A material's uniform dissolve.
#[derive(Clone, Debug)]
pub(super) struct Dissolve {
    /// `d`, or 1 − `Tr`, clamped to [0, 1].
    pub d: f32,
    /// The statement as the MTL file has it (`d 0.3`, `Tr 1`), for warnings.
    pub said: String,
}

/// The dissolve of material `mat` (see the module's documentation): `d`, else 1 − `Tr`;
/// None when it has neither, `Tr` is not a number, `d` is NaN, or it names a `map_d`.
pub(super) fn dissolve(mat: &tobj::Material) -> Option<Dissolve> {
    if mat.dissolve_texture.is_some() {
        return None;
    }
    let (d, said) = match (mat.dissolve, mat.unknown_param.get("Tr")) {
        (Some(d), _) => (d, format!("d {d}")),
        (None, Some(tr)) => (1.0 - tr.trim().parse::<f32>().ok()?, format!("Tr {tr}")),
        (None, None) => return None,
    };
    (!d.is_nan()).then(|| Dissolve {
        d: d.clamp(0.0, 1.0),
        said,
    })
}

/// The cut-outs of one OBJ file: the triangles they may still add ([`MAX_ADDED`] at first).
pub(super) struct Cutouts {
    left: usize,
    capped: bool,
}

impl Default for Cutouts {
    fn default() -> Self {
        Cutouts {
            left: MAX_ADDED,
            capped: false,
        }
    }
}

impl Cutouts {
    /// Cut `object` by its material's `map_d` texture `map` (named `material`), with a
    /// warning saying what the cut-outs cost. False (with a warning) when nothing of it is
    /// left: the object is then left out.
    pub fn apply(
        &mut self,
        obj: &Path,
        object: &mut Object,
        material: &str,
        map: &Texture,
        warnings: &mut Vec<String>,
    ) -> bool {
        let mask = Mask {
            texture: map,
            cutoff: MAP_D_CUTOFF,
            factor: 1.0,
            color_alpha: None,
        };
        let Some(cut) = cut(&mut object.mesh, &mask, &mut self.left) else {
            return true;
        };
        let (place, file) = (
            format!("{}: object '{}'", obj.display(), object.name),
            &map.image.name,
        );
        if cut.capped && !self.capped {
            self.capped = true;
            warnings.push(format!(
                "{}: map_d cut-outs stopped at {MAX_ADDED} added triangles for the file: the triangles left are treated as opaque",
                obj.display()
            ));
        }
        if cut.to == 0 {
            warnings.push(format!(
                "{place} skipped (it neither reflects nor blocks light): material '{material}' has map_d '{file}' below {MAP_D_CUTOFF} everywhere on it"
            ));
            return false;
        }
        warnings.push(format!(
            "{place}: material '{material}' map_d '{file}' cut-outs resolved to {} triangle(s) from {} (alpha below {MAP_D_CUTOFF} cut away; each triangle is lit as a patch or more)",
            cut.to, cut.from
        ));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(file: &str) -> MapSpec {
        MapSpec {
            file: file.to_string(),
            clamp: false,
            offset: Vec2::ZERO,
            scale: Vec2::ONE,
            channel: None,
        }
    }

    #[test]
    fn map_options_are_read_or_skipped_before_the_file() {
        assert_eq!(parse_map("leaf.png"), spec("leaf.png"));
        assert_eq!(parse_map("my leaf.png"), spec("my leaf.png"));
        let s = parse_map("-clamp on -imfchan m -o 0.5 0.25 -s 2 3 1 leaf.png");
        assert!(s.clamp);
        assert_eq!(s.channel, Some('m'));
        assert_eq!(
            (s.offset, s.scale),
            (Vec2::new(0.5, 0.25), Vec2::new(2.0, 3.0))
        );
        assert_eq!(s.file, "leaf.png");
        assert_eq!(parse_map("-bm 0.5 -mm 0 1 -t 1 leaf.png").file, "leaf.png");
        assert_eq!(parse_map("-unknown 1 2 on leaf.png").file, "leaf.png");
        // An option with nothing left for the file: the last word is the file.
        assert_eq!(parse_map("-clamp leaf.png").file, "leaf.png");
    }
}
