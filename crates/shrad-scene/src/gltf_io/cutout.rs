//! `alphaMode: MASK` with a base colour texture, resolved in geometry at load by the shared
//! [`crate::cutout`]: each triangle of the primitive is replaced by the parts of it whose
//! base colour alpha (the texture's, with the material's sampler, times the factor's, times
//! `COLOR_0`'s if the primitive has one) is at least `alphaCutoff` (glTF 2.0, "Alpha
//! Coverage"; default 0.5).

use super::{mesh::Place, walk::Walk};
use crate::cutout::{cut, Mask, MAX_ADDED};
use crate::{Material, Mesh};

impl Walk<'_> {
    /// Cut a MASK primitive's `shape` by its base colour texture's alpha (see
    /// [`crate::cutout`]), with a warning saying how many triangles the cut-outs made. False
    /// (with a warning) when nothing of it is left: the primitive is then skipped.
    pub(super) fn cut_mask<'a, 's, F>(
        &mut self,
        prim: &gltf::Primitive,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        shape: &mut Mesh,
        material: &Material,
        at: &Place,
    ) -> bool
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let m = prim.material();
        let Some(texture) = &material.base_color_texture else {
            return true;
        };
        if m.alpha_mode() != gltf::material::AlphaMode::Mask {
            return true;
        }
        let n = shape.positions.len();
        let color_alpha = reader
            .read_colors(0)
            .map(|c| c.into_rgba_f32().map(|c| c[3].clamp(0.0, 1.0)).collect())
            .filter(|c: &Vec<f32>| c.len() == n && c.iter().any(|&a| a < 1.0));
        let mask = Mask {
            texture,
            cutoff: m.alpha_cutoff().unwrap_or(0.5),
            factor: super::material::base_color(&m).0[3],
            color_alpha,
        };
        let Some(cut) = cut(shape, &mask, &mut self.cutout_left) else {
            return true;
        };
        let who = match (m.index(), m.name()) {
            (Some(i), Some(name)) => format!("materials[{i}] '{name}'"),
            (Some(i), None) => format!("materials[{i}]"),
            (None, _) => "the default material".to_string(),
        };
        let (place, cutoff) = (at.both(), mask.cutoff);
        if cut.capped && !self.cutout_capped {
            self.cutout_capped = true;
            self.scene.warnings.push(format!(
                "{place}: alphaMode MASK cut-outs stopped at {MAX_ADDED} added triangles for the file: the triangles left are treated as opaque"
            ));
        }
        if cut.to == 0 {
            self.scene.warnings.push(format!(
                "{place}: skipped (it neither reflects nor blocks light): {who} is alphaMode MASK and its base colour alpha is below its alphaCutoff {cutoff} everywhere on it"
            ));
            return false;
        }
        self.scene.warnings.push(format!(
            "{place}: {who} alphaMode MASK cut-outs resolved to {} triangle(s) from {} (alpha below the alphaCutoff {cutoff} cut away; each triangle is lit as a patch or more)",
            cut.to, cut.from
        ));
        true
    }
}
