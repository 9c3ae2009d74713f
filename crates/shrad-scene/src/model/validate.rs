//! What every solver relies on, checked once when a scene is loaded.

use std::path::Path;

use crate::{Scene, SceneError};

impl Scene {
    /// Check what every solver relies on: finite positions and transforms, indices in range,
    /// reflectance in [0,1), finite non-negative emission, no zero-area triangles (or drop them
    /// when `drop_degenerate`), at least one triangle. Errors name `path` and the object.
    pub fn validate(&mut self, path: &Path, drop_degenerate: bool) -> Result<(), SceneError> {
        if self.objects.is_empty() {
            return Err(SceneError::invalid(path, "the scene has no objects"));
        }
        for (oi, o) in self.objects.iter_mut().enumerate() {
            let who = format!("object {oi} '{}'", o.name);
            if let Some(i) = o.mesh.positions.iter().position(|p| !p.is_finite()) {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: vertex {i} is not finite ({})", o.mesh.positions[i]),
                ));
            }
            let n = o.mesh.positions.len() as u32;
            if let Some(t) = o
                .mesh
                .triangles
                .iter()
                .position(|t| t.iter().any(|&i| i >= n))
            {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{who}: triangle {t} has vertex index out of range ({:?}, {n} vertices)",
                        o.mesh.triangles[t]
                    ),
                ));
            }
            let m = o.world_from_object;
            if !(m.matrix3.is_finite() && m.translation.is_finite())
                || m.matrix3.determinant().abs() < 1e-12
            {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: transform is not finite or is singular"),
                ));
            }
            if let Some(k) = o
                .mesh
                .uvs
                .iter()
                .position(|s| s.len() != o.mesh.positions.len())
            {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{who}: texture coordinate set {k} has {} entries for {n} vertices",
                        o.mesh.uvs[k].len()
                    ),
                ));
            }
            let colors = o.mesh.colors.len();
            if colors != 0 && colors != o.mesh.positions.len() {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: {colors} vertex colours for {n} vertices"),
                ));
            }
            if let Some(i) = o
                .mesh
                .colors
                .iter()
                .position(|c| !c.is_finite() || c.min_element() < 0.0 || c.max_element() > 1.0)
            {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "{who}: vertex colour {i} ({}) must be in [0, 1]",
                        o.mesh.colors[i]
                    ),
                ));
            }
            for (what, t) in [
                ("base colour", &o.material.base_color_texture),
                ("emissive", &o.material.emissive_texture),
            ] {
                if let Some(t) = t {
                    if t.tex_coord as usize >= o.mesh.uvs.len() {
                        return Err(SceneError::invalid(
                            path,
                            format!(
                                "{who}: the {what} texture reads TEXCOORD_{} but the mesh has {} texture coordinate set(s)",
                                t.tex_coord,
                                o.mesh.uvs.len()
                            ),
                        ));
                    }
                }
            }
            let r = o.material.reflectance;
            if !r.is_finite() || r.min_element() < 0.0 || r.max_element() >= 1.0 {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: reflectance {r} must be in [0, 1) (energy conservation)"),
                ));
            }
            let e = o.material.emitted_radiance;
            if !e.is_finite() || e.min_element() < 0.0 {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: emitted radiance {e} must be finite and >= 0"),
                ));
            }
            let scale = o.mesh.bounds().map_or(0.0, |b| b.diagonal());
            let eps = 1e-10 * scale * scale;
            let degenerate: Vec<usize> = (0..o.mesh.triangles.len())
                .filter(|&t| {
                    o.mesh.triangle_area(t).partial_cmp(&eps) != Some(std::cmp::Ordering::Greater)
                })
                .collect();
            if !degenerate.is_empty() {
                if !drop_degenerate {
                    return Err(SceneError::invalid(
                        path,
                        format!(
                            "{who}: {} zero-area triangle(s), first is triangle {} {:?} (use --drop-degenerate to skip them)",
                            degenerate.len(),
                            degenerate[0],
                            o.mesh.triangles[degenerate[0]]
                        ),
                    ));
                }
                self.warnings.push(format!(
                    "{who}: dropped {} zero-area triangle(s)",
                    degenerate.len()
                ));
                let mut k = 0;
                o.mesh.triangles.retain(|_| {
                    let keep = degenerate.binary_search(&k).is_err();
                    k += 1;
                    keep
                });
            }
            if o.mesh.triangles.is_empty() {
                return Err(SceneError::invalid(
                    path,
                    format!("{who}: has no triangles"),
                ));
            }
        }
        if !self.has_emitter() {
            self.warnings
                .push("the scene has no emitter: every result will be black".to_string());
        }
        Ok(())
    }
}
