//! One object definition into objects: the keys it may have, its material, rest transform
//! and animation, and the primitive shapes.

use glam::{Affine3A, Vec3};

use super::transform::{animation, finite3, rest_transform};
use super::{mesh_file, ObjectDef, SceneBuilder, Shape};
use crate::builtin::{box_mesh, quad, sphere_mesh};
use crate::{Animation, Material, Mesh, Object};

/// What every object of one definition shares, whatever its shape.
pub(super) struct Common {
    pub name: String,
    pub rest: Affine3A,
    pub animation: Option<Animation>,
    /// The definition's own material (the defaults where it gives none).
    pub material: Material,
    /// The reflectance and emission it gives, which replace a mesh file's.
    pub reflectance: Option<Vec3>,
    pub emission: Option<Vec3>,
}

impl Common {
    /// An object of this definition with `mesh` and `material`.
    pub fn make(&self, o: &ObjectDef, mesh: Mesh, material: Material) -> Object {
        let mut obj = Object::new(self.name.clone(), mesh, material);
        obj.role = o.role;
        obj.world_from_object = self.rest;
        obj.animation = self.animation.clone();
        obj.patch_size = o.patch_size;
        obj
    }
}

pub(super) fn build(
    builder: &mut SceneBuilder,
    index: usize,
    shape: Shape,
    mut o: ObjectDef,
) -> Result<Vec<Object>, String> {
    check_keys_apply(&o, shape)?;
    let common = common(&o, index)?;
    let material = common.material.clone();
    match shape {
        Shape::Quad => Ok(vec![common.make(&o, quad_mesh(&o)?, material)]),
        Shape::Box => Ok(vec![common.make(&o, box_of(&o)?, material)]),
        Shape::Sphere => Ok(vec![common.make(&o, sphere_of(&o)?, material)]),
        Shape::Mesh => match (o.file.clone(), o.mesh_data.take()) {
            (Some(_), Some(_)) => {
                Err("give 'file' or mesh data ('positions', 'triangles'), not both".into())
            }
            (None, Some(mesh)) => {
                if let Some(key) = file_filter(&o) {
                    return Err(format!("'{key}' applies to a mesh 'file' only"));
                }
                Ok(vec![common.make(&o, mesh, material)])
            }
            (Some(file), None) => mesh_file::parts(builder, &o, &common, &file),
            (None, None) => Err(
                "shape 'mesh' needs 'file' (or, from Python, 'positions' and 'triangles')".into(),
            ),
        },
    }
}

/// Keys that belong to another shape are mistakes, not silently ignored.
fn check_keys_apply(o: &ObjectDef, shape: Shape) -> Result<(), String> {
    let given: [(&str, bool, Shape); 10] = [
        ("corners", o.corners.is_some(), Shape::Quad),
        ("size", o.size.is_some(), Shape::Box),
        ("inward", o.inward.is_some(), Shape::Box),
        ("radius", o.radius.is_some(), Shape::Sphere),
        ("segments", o.segments.is_some(), Shape::Sphere),
        ("file", o.file.is_some(), Shape::Mesh),
        ("node", o.node.is_some(), Shape::Mesh),
        ("mesh", o.mesh.is_some(), Shape::Mesh),
        ("animation", o.animation.is_some(), Shape::Mesh),
        ("positions", o.mesh_data.is_some(), Shape::Mesh),
    ];
    for (key, present, belongs) in given {
        if present && belongs != shape {
            return Err(format!(
                "'{key}' does not apply to shape '{}'",
                format!("{shape:?}").to_lowercase()
            ));
        }
    }
    Ok(())
}

/// The first key that selects from a mesh file, if any is given.
fn file_filter(o: &ObjectDef) -> Option<&'static str> {
    [
        ("node", o.node.is_some()),
        ("mesh", o.mesh.is_some()),
        ("animation", o.animation.is_some()),
    ]
    .into_iter()
    .find_map(|(key, given)| given.then_some(key))
}

/// Name, rest transform, animation and material, checked.
fn common(o: &ObjectDef, index: usize) -> Result<Common, String> {
    let name = o.name.clone().unwrap_or_else(|| format!("object{index}"));
    let rest = rest_transform(o)?;
    if o.patch_size.is_some_and(|h| !(h > 0.0 && h.is_finite())) {
        return Err("patch_size must be positive".into());
    }
    let reflectance = o
        .reflectance
        .map(|r| finite3(r, "reflectance"))
        .transpose()?;
    // As a reflectance key's: 1 is read as 0.999 (with a warning, `clamp_reflectance`), more
    // is a mistake (a file's 1.5 was clamped with a warning, a dict's refused).
    if let Some(r) = reflectance.filter(|r| r.min_element() < 0.0 || r.max_element() > 1.0) {
        return Err(format!(
            "reflectance {r} must be within [0, 1] (1 is read as {})",
            crate::MAX_REFLECTANCE
        ));
    }
    let emission = o.emission.map(|e| finite3(e, "emission")).transpose()?;
    if emission.is_some_and(|e| e.min_element() < 0.0) {
        return Err("emission must be >= 0".into());
    }
    let animation = animation(o)?;
    // Without an emission of its own, the object starts at its first emission key's.
    let keyed_emission = animation
        .as_ref()
        .and_then(|a| a.emission_at(f32::NEG_INFINITY));
    let material = Material {
        reflectance: reflectance.unwrap_or(Material::default().reflectance),
        emitted_radiance: emission.or(keyed_emission).unwrap_or(Vec3::ZERO),
        double_sided: o.double_sided.unwrap_or(false),
        base_color_texture: None,
        emissive_texture: None,
    };
    Ok(Common {
        name,
        rest,
        animation,
        material,
        reflectance,
        emission,
    })
}

fn quad_mesh(o: &ObjectDef) -> Result<Mesh, String> {
    let c = o
        .corners
        .as_ref()
        .ok_or("shape 'quad' needs 'corners' (4 points)")?;
    let c: [[f32; 3]; 4] = c
        .as_slice()
        .try_into()
        .map_err(|_| format!("'corners' must have 4 points, not {}", c.len()))?;
    Ok(quad(c.map(Vec3::from)))
}

fn box_of(o: &ObjectDef) -> Result<Mesh, String> {
    let size = finite3(
        o.size.ok_or("shape 'box' needs 'size' = [w, h, d]")?,
        "size",
    )?;
    if size.min_element() <= 0.0 {
        return Err(format!("size {size} must be positive"));
    }
    Ok(box_mesh(0.5 * size, o.inward.unwrap_or(false)))
}

fn sphere_of(o: &ObjectDef) -> Result<Mesh, String> {
    let r = o.radius.ok_or("shape 'sphere' needs 'radius'")?;
    if !(r > 0.0 && r.is_finite()) {
        return Err(format!("radius {r} must be positive"));
    }
    let segments = o.segments.unwrap_or(32);
    if !(3..=512).contains(&segments) {
        return Err(format!("segments {segments} must be in 3..=512 (512 segments make 261,120 triangles; patches subdivide further)"));
    }
    Ok(sphere_mesh(r, segments))
}
