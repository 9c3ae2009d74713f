//! What every solver relies on, checked once when a scene is loaded.

use std::path::Path;

use crate::{Aabb, Object, Scene, SceneError};

impl Scene {
    /// Check what every solver relies on: finite positions and transforms, indices in range,
    /// reflectance in [0,1), finite non-negative emission, no zero-area triangles (or drop them
    /// when `drop_degenerate`), at least one triangle. Errors name `path` and the object.
    pub fn validate(&mut self, path: &Path, drop_degenerate: bool) -> Result<(), SceneError> {
        if self.objects.is_empty() {
            return Err(SceneError::invalid(path, "the scene has no objects"));
        }
        self.validate_may_be_empty(path, drop_degenerate)
    }

    /// [`Scene::validate`] for a scene that may have no objects: a valid glTF file whose
    /// scene draws nothing to light loads empty, as a viewer opens it (its reader has
    /// warned why); the engine takes an empty scene and its pictures are the background.
    pub(crate) fn validate_may_be_empty(
        &mut self,
        path: &Path,
        drop_degenerate: bool,
    ) -> Result<(), SceneError> {
        self.validate_lights(path)?;
        for (oi, o) in self.objects.iter_mut().enumerate() {
            let who = format!("object {oi} '{}'", o.name);
            let problem = geometry_problem(o)
                .or_else(|| attribute_problem(o))
                .or_else(|| material_problem(&o.material))
                .map_or(Ok(()), Err)
                .and_then(|()| {
                    drop_degenerate_triangles(o, drop_degenerate, &who, &mut self.warnings)
                });
            if let Err(why) = problem {
                return Err(SceneError::invalid(path, format!("{who}: {why}")));
            }
        }
        self.warn_enclosed_lights();
        if !self.has_emitter() && !self.objects.is_empty() {
            self.warnings
                .push("the scene has no emitter: every result will be black".to_string());
        }
        Ok(())
    }
}

/// What is wrong with an object's vertices, triangles or transform, if anything: a vertex
/// that is not finite, an index out of range, a transform that is not finite or is singular.
fn geometry_problem(o: &Object) -> Option<String> {
    if let Some(i) = o.mesh.positions.iter().position(|p| !p.is_finite()) {
        return Some(format!(
            "vertex {i} is not finite ({})",
            o.mesh.positions[i]
        ));
    }
    let n = o.mesh.positions.len() as u32;
    if let Some(t) = o
        .mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&i| i >= n))
    {
        return Some(format!(
            "triangle {t} has vertex index out of range ({:?}, {n} vertices)",
            o.mesh.triangles[t]
        ));
    }
    if let Some(why) = transform_problem(o.world_from_object) {
        return Some(why);
    }
    // One pass over the vertices for the size and the reach (no vertex: size 0).
    let bounds = o.world_bounds();
    let size = bounds.map_or(0.0, |b| b.diagonal());
    if size < MIN_SIZE {
        return Some(format!(
            "its world size is {size:.1e}, below the {MIN_SIZE:.0e} under which 32-bit \
             arithmetic of its areas loses them: scale the scene up"
        ));
    }
    extent_problem(bounds?).map(|why| format!("{why}: scale the scene down"))
}

/// What makes `world_from_local` no place for a shape whose vertices span `local` (in its
/// own frame), if anything: a transform that is not finite or flattens space, or one that
/// puts the shape beyond [`MAX_COORDINATE`]. An animation's pose at some time, or a
/// `set_transform`, is checked by it before anything moves: such a pose made the visibility
/// backend abort (Embree's assertion on a ray that is not valid), not fail.
pub fn placement_problem(world_from_local: glam::Affine3A, local: Option<Aabb>) -> Option<String> {
    transform_problem(world_from_local).or_else(|| {
        let world = local?.transformed(world_from_local);
        extent_problem(world).or_else(|| {
            let size = world.diagonal();
            (size < MIN_SIZE).then(|| {
                format!(
                    "its world size would be {size:.1e}, below the {MIN_SIZE:.0e} under which \
                     32-bit arithmetic of its areas loses them"
                )
            })
        })
    })
}

/// What is wrong with a transform, if anything: not finite, or flattening space (to a
/// plane, a line or a point: [`is_singular`]). Its columns are named in the message.
pub fn transform_problem(m: glam::Affine3A) -> Option<String> {
    let columns = || {
        [
            m.matrix3.x_axis,
            m.matrix3.y_axis,
            m.matrix3.z_axis,
            m.translation,
        ]
        .map(|c| c.to_array())
    };
    if !(m.matrix3.is_finite() && m.translation.is_finite()) {
        return Some(format!(
            "transform is not finite (its columns: {:?})",
            columns()
        ));
    }
    is_singular(&glam::Mat3::from(m.matrix3)).then(|| {
        format!(
            "transform is singular, or all but: it flattens the object (its columns: {:?})",
            columns()
        )
    })
}

/// What is wrong with where `world` (a shape's bounds in the world) puts it, if anything:
/// beyond [`MAX_COORDINATE`] from the origin, or wider than [`MAX_SIZE`].
fn extent_problem(world: Aabb) -> Option<String> {
    let reach = world.min.abs().max(world.max.abs()).max_element();
    if reach.is_nan() || reach > MAX_COORDINATE {
        return Some(format!(
            "its world coordinates reach {reach:.1e}, beyond the {MAX_COORDINATE:.0e} that \
             32-bit arithmetic of its areas and distances can hold"
        ));
    }
    let size = world.diagonal();
    (size > MAX_SIZE).then(|| {
        format!(
            "its world size is {size:.1e}, beyond the {MAX_SIZE:.0e} over which 32-bit \
             arithmetic of its triangles' areas overflows"
        )
    })
}

/// The largest world coordinate a scene may have: its squared distances and areas (up to
/// 1e24) stay far from the 3.4e38 where 32-bit floats overflow (a node scaled by 1e30 made
/// every area infinite, and the first error was about an infinite patch size).
pub const MAX_COORDINATE: f32 = 1e12;

/// The largest world size (box diagonal) an object may have: a triangle's area is half the
/// length of a cross product, whose square (edges to the fourth power) overflows 32-bit
/// floats past edges of about 4e9 (a room of side 1e10 had infinite areas, and the first
/// error was about an infinite patch size; one of 1e11 solved to NaN errors).
pub(crate) const MAX_SIZE: f32 = 1e9;

/// The smallest world size (box diagonal) an object may have: its patches' areas (down to
/// about 1e-24) stay far from the 1e-38 below which 32-bit floats lose them (a node scaled
/// by 1e-30 loaded as 12 patches of no area and a black picture).
pub(crate) const MIN_SIZE: f32 = 1e-9;

/// What is wrong with an object's texture coordinates, vertex colours or the texture
/// coordinate sets its textures read, if anything.
fn attribute_problem(o: &Object) -> Option<String> {
    let n = o.mesh.positions.len();
    if let Some(k) = o.mesh.uvs.iter().position(|s| s.len() != n) {
        return Some(format!(
            "texture coordinate set {k} has {} entries for {n} vertices",
            o.mesh.uvs[k].len()
        ));
    }
    let lightmap = o.mesh.lightmap_uvs.len();
    if lightmap != 0 && lightmap != n {
        return Some(format!(
            "{lightmap} lightmap texture coordinates for {n} vertices"
        ));
    }
    if let Some(i) = o.mesh.lightmap_uvs.iter().position(|p| !p.is_finite()) {
        return Some(format!("lightmap texture coordinate {i} is not finite"));
    }
    let colors = o.mesh.colors.len();
    if colors != 0 && colors != n {
        return Some(format!("{colors} vertex colours for {n} vertices"));
    }
    if let Some(i) = o
        .mesh
        .colors
        .iter()
        .position(|c| !c.is_finite() || c.min_element() < 0.0 || c.max_element() > 1.0)
    {
        return Some(format!(
            "vertex colour {i} ({}) must be in [0, 1]",
            o.mesh.colors[i]
        ));
    }
    for (what, t) in [
        ("base colour", &o.material.base_color_texture),
        ("emissive", &o.material.emissive_texture),
    ] {
        if let Some(t) = t
            .as_ref()
            .filter(|t| t.tex_coord as usize >= o.mesh.uvs.len())
        {
            return Some(format!(
                "the {what} texture reads TEXCOORD_{} but the mesh has {} texture coordinate set(s)",
                t.tex_coord,
                o.mesh.uvs.len()
            ));
        }
    }
    None
}

/// Zero-area triangles are an error, or dropped with a warning when `drop`; repeated ones
/// ([`crate::Mesh::repeated_triangles`]) are dropped with a warning; an object without
/// triangles is an error.
fn drop_degenerate_triangles(
    o: &mut Object,
    drop: bool,
    who: &str,
    warnings: &mut Vec<String>,
) -> Result<(), String> {
    let degenerate = o.mesh.zero_area_triangles();
    if let Some(&first) = degenerate.first() {
        if !drop {
            return Err(format!(
                "{} zero-area triangle(s), first is triangle {first} {:?} (use --drop-degenerate to skip them)",
                degenerate.len(),
                o.mesh.triangles[first]
            ));
        }
        warnings.push(format!(
            "{who}: dropped {} zero-area triangle(s)",
            degenerate.len()
        ));
        o.mesh.remove_triangles(&degenerate);
    }
    let repeated = o.mesh.repeated_triangles();
    if !repeated.is_empty() {
        warnings.push(format!(
            "{who}: dropped {} repeated triangle(s) (the corners of an earlier one, facing the \
             same way: one surface lit as many would count its light again for each)",
            repeated.len()
        ));
        o.mesh.remove_triangles(&repeated);
    }
    if o.mesh.triangles.is_empty() {
        return Err("has no triangles".into());
    }
    Ok(())
}

impl Scene {
    /// Every light's values are valid (`Light::problem`).
    fn validate_lights(&self, path: &Path) -> Result<(), SceneError> {
        for (li, l) in self.lights.iter().enumerate() {
            if let Some(why) = l.problem() {
                return Err(SceneError::invalid(
                    path,
                    format!("light {li} '{}': {why}", l.name),
                ));
            }
        }
        Ok(())
    }
}

/// What is wrong with a material's values, if anything: a reflectance outside [0, 1) or an
/// emission that is negative or not finite.
fn material_problem(m: &crate::Material) -> Option<String> {
    let r = m.reflectance;
    if !r.is_finite() || r.min_element() < 0.0 || r.max_element() >= 1.0 {
        return Some(format!(
            "reflectance {r} must be in [0, 1) (energy conservation)"
        ));
    }
    emission_problem(m.emitted_radiance)
}

/// The largest radiance (W/(m^2 sr)) a surface, the sky or a punctual light (its intensity
/// in W/sr, its irradiance in W/m^2) may have: 13 orders of magnitude above the sun's disc,
/// and far enough below the 3.4e38 where 32-bit floats overflow that the sums of a solve
/// stay finite (an emission of 1e38 loaded, every frame diverged to infinity and the picture
/// was black).
pub const MAX_RADIANCE: f32 = 1e20;

/// What is wrong with an emitted radiance, if anything: negative, not finite, or beyond
/// [`MAX_RADIANCE`].
pub fn emission_problem(e: glam::Vec3) -> Option<String> {
    if !e.is_finite() || e.min_element() < 0.0 {
        return Some(format!("emitted radiance {e} must be finite and >= 0"));
    }
    (e.max_element() > MAX_RADIANCE).then(|| {
        format!(
            "emitted radiance up to {:.3e} is beyond the {MAX_RADIANCE:.0e} W/(m^2 sr) a solve can hold",
            e.max_element()
        )
    })
}

/// Whether a linear map flattens space (to a plane, a line or a point), or all but does,
/// relative to its own scale: a determinant that is tiny beside the product of its columns'
/// lengths (a shear that collapses), or a condition number over 1e7 (one axis
/// squashed beside another). (An absolute bound on the determinant refused a scene
/// modelled in micrometres.) (In f64: a scale of 1e30 is finite, its cube is not in f32.)
pub fn is_singular(m: &glam::Mat3) -> bool {
    let m = m.as_dmat3();
    let scale = m.x_axis.length() * m.y_axis.length() * m.z_axis.length();
    if !(m.determinant().abs() > 1e-6 * scale && scale > 0.0) {
        return true;
    }
    let frobenius = |m: glam::DMat3| m.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt();
    // |M|_F |M^-1|_F bounds the 2-norm condition number from above, within a factor of 3.
    let condition = frobenius(m) * frobenius(m.inverse());
    condition.is_nan() || condition > MAX_CONDITION
}

/// The largest condition number (Frobenius norms) a transform may have: an object squashed
/// along one axis by 1e-16 beside the others made Embree abort (its instance-space rays
/// left the range it accepts) and the pure-Rust BVH give NaN; 1e7 refuses squashes beyond
/// about 1e-7, far from both, and keeps a rod of 1:1000.
const MAX_CONDITION: f64 = 1e7;

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Affine3A, Vec3};

    fn unit_box() -> Option<Aabb> {
        Some(Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        })
    }

    /// A pose an animation or a move would take is named by its columns, as a scene file's
    /// transform is, never by Rust's debug text of the matrix.
    #[test]
    fn a_bad_placement_names_its_columns_and_says_what_is_wrong() {
        let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
        let why = placement_problem(flat, unit_box()).unwrap();
        assert!(
            why.contains("singular")
                && why.contains("its columns: [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]")
                && !why.contains("Affine3A"),
            "{why}"
        );
        let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
        let why = placement_problem(nan, unit_box()).unwrap();
        assert!(why.contains("not finite") && why.contains("NaN"), "{why}");
        let far = Affine3A::from_translation(Vec3::splat(2.0 * MAX_COORDINATE));
        let why = placement_problem(far, unit_box()).unwrap();
        assert!(why.contains("world coordinates reach 2.0e12"), "{why}");
        let wide = Affine3A::from_scale(Vec3::splat(MAX_SIZE));
        let why = placement_problem(wide, unit_box()).unwrap();
        assert!(why.contains("world size is 1.7e9"), "{why}");
        // All but flat: one axis squashed by 1e-16 beside the others (Embree aborted).
        let squashed = Affine3A::from_scale(Vec3::new(1e-16, 1.0, 1.0));
        let why = placement_problem(squashed, unit_box()).unwrap();
        assert!(why.contains("singular"), "{why}");
        // A rod of 1:1000, turned, is no problem; nor a small uniform scale, nor a shape
        // without bounds.
        let rod = Affine3A::from_quat(glam::Quat::from_rotation_x(0.7))
            * Affine3A::from_scale(Vec3::new(1e-3, 1e-3, 1.0));
        assert_eq!(placement_problem(rod, unit_box()), None);
        let small = Affine3A::from_scale(Vec3::splat(1e-4));
        assert_eq!(placement_problem(small, unit_box()), None);
        // Shrunk below the smallest size a scene may load at (the BVH's rays gave NaN).
        let tiny = Affine3A::from_scale(Vec3::splat(1e-20));
        let why = placement_problem(tiny, unit_box()).unwrap();
        assert!(
            why.contains("world size would be") && why.contains("below the 1e-9"),
            "{why}"
        );
        assert_eq!(placement_problem(Affine3A::IDENTITY, None), None);
    }
}
