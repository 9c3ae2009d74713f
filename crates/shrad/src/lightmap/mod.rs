//! Lightmaps: the light of every object in one texture atlas over a second UV set
//! (`shrad bake --lightmap`), at texel detail rather than at the patches' vertices.
//!
//! - **Charts** ([`chart`]): the object's own lightmap UVs (`TEXCOORD_1`) when usable
//!   ([`uv_chart`]), else the patches' own planar faces, each projected onto its plane,
//!   grown over curved meshes into near-flat charts ([`grow`]);
//! - **Packing** ([`pack`]): the charts' rectangles, each with `padding` texels around it,
//!   in shelves; the texel size is given (`texel_size`, metres) or found so that the atlas
//!   fits `resolution` x `resolution`;
//! - **Texels** ([`texel`]): each texel of a chart is the point of the chart's plane at its
//!   centre; its irradiance is what a picture shows there ([`crate::render::SurfaceLight`]:
//!   the patches' irradiance reconstructed smoothly, its punctual part replaced by the exact
//!   punctual irradiance with a shadow ray, [`crate::lights::point_irradiance`]); the
//!   padding is filled by dilation so bilinear filtering never reads black;
//! - **Output** ([`output`]): the glTF with `TEXCOORD_1`, the lightmap as PNGs inside it and
//!   beside it as a linear OpenEXR or, for 8-bit pipelines, an RGBM PNG ([`rgbm`]).

pub mod chart;
pub mod grow;
pub mod output;
pub mod pack;
pub mod rgbm;
pub mod texel;
pub mod uv_chart;
pub mod view;

use glam::Vec2;

use crate::{Error, World};
use chart::Chart;

/// [`crate::bake::bake_with_progress`] with the light in a lightmap rather than per vertex:
/// each file `out.glb` with its `out.lightmap.exr` beside it ([`output`]), a sequence all
/// or nothing as there.
pub fn bake_with_progress(
    engine: &mut crate::engine::Engine,
    path: &std::path::Path,
    options: &crate::bake::BakeOptions,
    lightmap: &LightmapOptions,
    progress: &dyn crate::Progress,
) -> Result<Vec<crate::bake::Baked>, Error> {
    if let Some(why) = lightmap.problem() {
        return Err(Error::Invalid(format!("lightmap: {why}")));
    }
    crate::bake::bake_files(
        engine,
        path,
        options,
        progress,
        &|engine, file, e, staged| output::stage(engine, file, e, lightmap, staged),
    )
}

/// The top-left texel of each chart's rectangle.
type Places = Vec<(u32, u32)>;

/// Default atlas side when neither a texel size nor a resolution is given.
pub const DEFAULT_RESOLUTION: u32 = 1024;

/// How a lightmap is laid out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightmapOptions {
    /// Texel edge in metres (scene units); `None`: from `resolution`.
    pub texel_size: Option<f32>,
    /// The atlas's side in texels when `texel_size` is `None` ([`DEFAULT_RESOLUTION`] when
    /// both are `None`).
    pub resolution: Option<u32>,
    /// Texels of padding around each chart (at least 1).
    pub padding: u32,
    /// Largest angle (degrees) between a grown chart's axis (its mean normal) and its
    /// patches ([`grow::MAX_ANGLE_DEG`]); 0: planar charts only, a curved mesh a chart per input
    /// triangle.
    pub max_chart_angle: f32,
    /// The lightmap file beside the glTF.
    pub format: LightmapFormat,
}

/// The lightmap file beside the glTF: both hold `E / pi` (W/m^2/sr) unclamped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightmapFormat {
    /// `OUT.lightmap.exr`: linear OpenEXR, 32-bit float RGB.
    #[default]
    Exr,
    /// `OUT.lightmap.png`: RGBM in an 8-bit RGBA PNG, the multiplier in the glTF ([`rgbm`]).
    Rgbm,
}

impl LightmapFormat {
    /// The names `--lightmap-format` takes.
    pub const NAMES: [&'static str; 2] = ["exr", "rgbm"];

    /// The format called `name` (as [`Self::NAMES`]); an error lists the names.
    pub fn from_name(name: &str) -> Result<LightmapFormat, Error> {
        match name {
            "exr" => Ok(LightmapFormat::Exr),
            "rgbm" => Ok(LightmapFormat::Rgbm),
            _ => Err(Error::Invalid(format!(
                "unknown lightmap format '{name}': use exr or rgbm"
            ))),
        }
    }
}

impl LightmapOptions {
    /// What is wrong with these options, if anything: a texel size that is not a positive
    /// number, an atlas side outside 8 to [`crate::limits::MAX_IMAGE_SIDE`] texels. (Every
    /// front end's own check, by its own names, comes first: `--texel-size`, `texel_size`.)
    pub fn problem(&self) -> Option<String> {
        if let Some(m) = self.texel_size.filter(|m| !(m.is_finite() && *m > 0.0)) {
            return Some(format!("the texel size must be a positive number, got {m}"));
        }
        let max = crate::limits::MAX_IMAGE_SIDE;
        if let Some(n) = self.resolution.filter(|n| !(8..=max).contains(n)) {
            return Some(format!(
                "the atlas's side must be 8 to {max} texels, got {n}"
            ));
        }
        None
    }
}

impl Default for LightmapOptions {
    fn default() -> Self {
        LightmapOptions {
            texel_size: None,
            resolution: None,
            padding: 2,
            max_chart_angle: grow::MAX_ANGLE_DEG,
            format: LightmapFormat::Exr,
        }
    }
}

/// The charts placed in the atlas.
#[derive(Clone, Debug)]
pub struct Layout {
    /// Every chart.
    pub charts: Vec<Chart>,
    /// Top-left texel of each chart's rectangle.
    pub at: Vec<(u32, u32)>,
    /// Texel edge (metres).
    pub texel: f32,
    /// Padding texels around each chart.
    pub padding: u32,
    /// Atlas width.
    pub width: u32,
    /// Atlas height.
    pub height: u32,
    /// Each patch's chart.
    pub chart_of_patch: Vec<u32>,
    /// Each patch's corners in atlas coordinates (texels from the top-left corner; corner
    /// order, a triangle repeats its last).
    pub corners: Vec<[Vec2; 4]>,
    /// What the user should know (an object's own UVs that could not be used).
    pub warnings: Vec<String>,
}

impl Layout {
    /// The continuous atlas coordinates (texels from the top-left corner) of patch `i` at
    /// its parameters `(s, t)` (as [`crate::render::SurfaceLight::params`] gives them): the
    /// corners' coordinates are an affine image of the patch, so this is exact.
    pub fn atlas_at(&self, i: usize, s: f32, t: f32) -> Vec2 {
        // A triangle's fourth corner repeats its third: the same formula serves both.
        let c = &self.corners[i];
        c[0] + (c[1] - c[0]) * s + (c[3] - c[0]) * t
    }

    /// The texture coordinates (0..1, glTF's: from the top-left) of atlas point `xy`.
    pub fn uv(&self, xy: Vec2) -> Vec2 {
        xy / Vec2::new(self.width as f32, self.height as f32)
    }
}

/// The rectangle (texels) of `chart` at texel size `texel` with `padding`.
fn rect(chart: &Chart, texel: f32, padding: u32) -> (u32, u32) {
    let e = (chart.max - chart.min) / texel;
    let side = |x: f32| (x.ceil().max(1.0) as u32).saturating_add(2 * padding);
    (side(e.x), side(e.y))
}

/// Pack `charts` at `texel` into rows of `width`: places and height.
fn pack_at(charts: &[Chart], texel: f32, padding: u32, width: u32) -> Option<(Places, u32)> {
    let sizes: Vec<(u32, u32)> = charts.iter().map(|c| rect(c, texel, padding)).collect();
    pack::shelves(&sizes, width)
}

/// The layout of `world`'s patches as `options` asks (its errors name the option).
pub fn layout(world: &World, options: &LightmapOptions) -> Result<Layout, Error> {
    let padding = options.padding.max(1);
    let (mut charts, charted, warnings) = uv_chart::uv_charts(world);
    let todo: Vec<bool> = charted.iter().map(|c| !c).collect();
    let planar = chart::planar_charts(world, &todo);
    charts.extend(grow::grow(world, planar, options.max_chart_angle));
    // Object by object (stable: an object's own UV chart first): each object is one mesh.
    charts.sort_by_key(|c| c.object);
    if charts.is_empty() {
        return Err(Error::Invalid(
            "the scene has no patches to lightmap".into(),
        ));
    }
    let max = crate::limits::MAX_IMAGE_SIDE;
    let (texel, at, width, height) = match (options.texel_size, options.resolution) {
        (Some(_), Some(_)) => {
            return Err(Error::Invalid(
                "give a lightmap texel size or a resolution, not both".into(),
            ))
        }
        (Some(t), None) => {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::Invalid(format!(
                    "the lightmap texel size must be a positive number of scene units, got {t}"
                )));
            }
            let (at, w, h) = pack_free(&charts, t, padding)
                .filter(|&(_, w, h)| w <= max && h <= max)
                .ok_or_else(|| {
                    Error::Invalid(format!(
                        "a lightmap texel of {t} scene units needs an atlas over {max} texels a side: give a larger texel size"
                    ))
                })?;
            (t, at, w, h)
        }
        (None, n) => {
            let n = n.unwrap_or(DEFAULT_RESOLUTION);
            if !(8..=max).contains(&n) {
                return Err(Error::Invalid(format!(
                    "the lightmap resolution must be 8 to {max} texels, got {n}"
                )));
            }
            let (t, at) = fit(&charts, padding, n)?;
            (t, at, n, n)
        }
    };
    check_atlas(&charts, texel, width, height)?;
    let mut chart_of_patch = vec![0u32; world.patches.len()];
    let mut corners = vec![[Vec2::ZERO; 4]; world.patches.len()];
    for (c, chart) in charts.iter().enumerate() {
        let corner = Vec2::new(at[c].0 as f32, at[c].1 as f32) + Vec2::splat(padding as f32);
        for (&i, q) in chart.patches.iter().zip(&chart.coords) {
            chart_of_patch[i] = c as u32;
            corners[i] = q.map(|q| corner + (q - chart.min) / texel);
        }
    }
    Ok(Layout {
        charts,
        at,
        texel,
        padding,
        width,
        height,
        chart_of_patch,
        corners,
        warnings,
    })
}

/// An atlas that can be baked: a texel no larger than the largest chart (else no texel's
/// centre falls on a patch and the lightmap is black), and texels the memory holds.
fn check_atlas(charts: &[Chart], texel: f32, width: u32, height: u32) -> Result<(), Error> {
    let largest = (charts.iter())
        .map(|c| (c.max - c.min).max_element())
        .fold(0.0f32, f32::max);
    if texel > largest {
        return Err(Error::Invalid(format!(
            "a lightmap texel of {texel:.3e} scene units is larger than the largest chart \
             ({largest:.3e} across): no texel would fall on a patch; give a smaller texel size"
        )));
    }
    crate::limits::check_lightmap(width, height)
}

/// Pack at `texel` into a near-square atlas: places, width and height (multiples of 4).
fn pack_free(charts: &[Chart], texel: f32, padding: u32) -> Option<(Places, u32, u32)> {
    let sizes: Vec<(u32, u32)> = charts.iter().map(|c| rect(c, texel, padding)).collect();
    let area: f64 = sizes.iter().map(|&(w, h)| w as f64 * h as f64).sum();
    let widest = sizes.iter().map(|s| s.0).max().unwrap_or(1);
    let width = ((1.1 * area.sqrt()).ceil() as u32)
        .max(widest)
        .next_multiple_of(4);
    let (at, height) = pack::shelves(&sizes, width)?;
    Some((at, width, height.max(1).next_multiple_of(4)))
}

/// The smallest texel size (to 2 %) at which the charts fit an `n` x `n` atlas, and the
/// places.
fn fit(charts: &[Chart], padding: u32, n: u32) -> Result<(f32, Vec<(u32, u32)>), Error> {
    let area: f32 = charts
        .iter()
        .map(|c| (c.max - c.min).x.max(0.0) * (c.max - c.min).y.max(0.0))
        .sum();
    let mut texel = (area / (0.8 * (n * n) as f32)).sqrt().max(1e-6);
    for _ in 0..400 {
        if let Some((at, h)) = pack_at(charts, texel, padding, n) {
            if h <= n {
                return Ok((texel, at));
            }
        }
        texel *= 1.02;
    }
    Err(Error::Invalid(format!(
        "{} lightmap charts (with {padding} texels of padding each) do not fit {n} x {n} texels: give a larger resolution",
        charts.len()
    )))
}
