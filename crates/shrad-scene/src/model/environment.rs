//! The sky: light from outside the scene, met by every ray that leaves it. A uniform
//! radiance, or an equirectangular map (linear OpenEXR or Radiance `.hdr`) whose top row is
//! +Y (glTF's up) and whose centre column looks along +Z (its left and right edges along
//! -Z), as Mitsuba 3's `envmap`: the direction of texel coordinates `(u, v)` in [0, 1]^2 is
//! `(sin(2 pi u) sin(pi v), cos(pi v), -cos(2 pi u) sin(pi v))`, turned by `rotate_deg`
//! about +Y (counter-clockwise seen from above), and its radiance is the texel's times
//! `scale`. Blender's Environment Texture has its centre column along +X (glTF axes):
//! `rotate_deg = 90` shows a map as Blender does.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use crate::SceneError;

/// Largest side of a map, in texels.
pub const MAX_ENV_SIDE: u32 = 16384;

/// An equirectangular map of linear radiance, row 0 at the top (+Y).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// The file it was read from.
    pub path: PathBuf,
    /// Texels across.
    pub width: u32,
    /// Texels down.
    pub height: u32,
    /// Linear RGB radiance, row by row from the top.
    pub texels: Vec<Vec3>,
}

impl EnvMap {
    /// The largest channel of its brightest texel.
    pub fn brightest(&self) -> f32 {
        (self.texels.iter()).fold(0.0, |m, t| m.max(t.max_element()))
    }

    /// Read a linear OpenEXR (`.exr`) or Radiance (`.hdr`) map. Errors name the file and
    /// what is wrong: unreadable, another format, too large, a negative or non-finite texel.
    pub fn load(path: &Path) -> Result<EnvMap, SceneError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("exr" | "hdr")) {
            return Err(SceneError::invalid(
                path,
                "an environment map must be a linear OpenEXR (.exr) or Radiance (.hdr) file",
            ));
        }
        if let Err(source) = std::fs::metadata(path) {
            return Err(SceneError::Io {
                path: path.to_path_buf(),
                source,
            });
        }
        let open = || {
            image::ImageReader::open(path)
                .and_then(|r| r.with_guessed_format())
                .map_err(|e| SceneError::invalid(path, format!("cannot read the map: {e}")))
        };
        // The size from the header, before the texels: a header declaring 100000x100000 was
        // "Memory limit exceeded", the decoder's own limit, not this one.
        let side_problem = |(width, height): (u32, u32)| {
            let bad = width == 0 || height == 0 || width > MAX_ENV_SIDE || height > MAX_ENV_SIDE;
            bad.then(|| {
                SceneError::invalid(
                    path,
                    format!("the map is {width}x{height}; each side must be 1..={MAX_ENV_SIDE}"),
                )
            })
        };
        if let Some(e) = open()?.into_dimensions().ok().and_then(side_problem) {
            return Err(e);
        }
        let img = open()?
            .decode()
            .map_err(|e| SceneError::invalid(path, format!("not a readable map: {e}")))?
            .into_rgb32f();
        let (width, height) = img.dimensions();
        if let Some(e) = side_problem((width, height)) {
            return Err(e);
        }
        let texels: Vec<Vec3> = img.pixels().map(|p| Vec3::from_array(p.0)).collect();
        EnvMap::new(path.to_path_buf(), width, height, texels)
    }

    /// A map from texels (row 0 at the top), checked: finite and non-negative.
    pub fn new(
        path: PathBuf,
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
    ) -> Result<EnvMap, SceneError> {
        if texels.len() != width as usize * height as usize || texels.is_empty() {
            return Err(SceneError::invalid(
                &path,
                format!("{} texels for a {width}x{height} map", texels.len()),
            ));
        }
        if let Some(k) = texels.iter().position(|t| !t.is_finite()) {
            let (x, y) = (k % width as usize, k / width as usize);
            return Err(SceneError::invalid(
                &path,
                format!("texel ({x}, {y}) is not a finite number ({})", texels[k]),
            ));
        }
        if let Some(k) = texels.iter().position(|t| t.min_element() < 0.0) {
            let (x, y) = (k % width as usize, k / width as usize);
            return Err(SceneError::invalid(
                &path,
                format!(
                    "texel ({x}, {y}) is negative ({}): radiance is >= 0",
                    texels[k]
                ),
            ));
        }
        Ok(EnvMap {
            path,
            width,
            height,
            texels,
        })
    }
}

/// The scene's sky.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Uniform radiance (W / (m^2 sr), linear RGB), used when there is no map.
    pub radiance: Vec3,
    /// An equirectangular map instead of the uniform radiance.
    pub map: Option<Arc<EnvMap>>,
    /// Rotation of the map about +Y, degrees (counter-clockwise seen from above).
    pub rotate_deg: f32,
    /// Factor on the map's (or the uniform) radiance.
    pub scale: f32,
}

impl Environment {
    /// A uniform sky of radiance `radiance`.
    pub fn uniform(radiance: Vec3) -> Environment {
        Environment {
            radiance,
            map: None,
            rotate_deg: 0.0,
            scale: 1.0,
        }
    }

    /// A sky from the map `map`.
    pub fn from_map(map: EnvMap) -> Environment {
        Environment {
            radiance: Vec3::ONE,
            map: Some(Arc::new(map)),
            rotate_deg: 0.0,
            scale: 1.0,
        }
    }

    /// What is wrong with it, if anything (for a message that names where it came from).
    pub fn problem(&self) -> Option<String> {
        if !self.radiance.is_finite() || self.radiance.min_element() < 0.0 {
            return Some(format!(
                "sky radiance {} must be finite and >= 0",
                self.radiance
            ));
        }
        if !(self.scale.is_finite() && self.scale >= 0.0) {
            return Some(format!("env scale {} must be finite and >= 0", self.scale));
        }
        let brightest = self.radiance.max_element()
            * self.scale
            * self.map.as_ref().map_or(1.0, |m| m.brightest());
        if brightest.is_nan() || brightest > crate::MAX_RADIANCE {
            return Some(format!(
                "sky radiance up to {brightest:.3e} (radiance x scale x the map's brightest texel) \
                 is beyond the {:.0e} W/(m^2 sr) a solve can hold",
                crate::MAX_RADIANCE
            ));
        }
        if !self.rotate_deg.is_finite() {
            return Some(format!("env rotate {} must be finite", self.rotate_deg));
        }
        None
    }

    /// Does it send no light at all?
    pub fn is_black(&self) -> bool {
        self.scale == 0.0
            || match &self.map {
                Some(m) => m.texels.iter().all(|t| t.max_element() <= 0.0),
                None => self.radiance.max_element() <= 0.0,
            }
    }
}
