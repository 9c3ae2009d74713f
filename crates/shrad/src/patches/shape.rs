//! An object's rest transform split by a polar decomposition into a rigid part
//! (`world_from_local`) and a shape (`local_from_object`: scale, shear, mirroring), and the
//! mesh with its shape applied: the local frame patches are cut and measured in.

use glam::{Affine3A, Mat3, Vec2};
use shrad_scene::{Mesh, Object, Scene};

/// Split a rest transform into a rigid part and a shape (polar decomposition, Higham's
/// iteration `R <- (R + R^-T) / 2` in f64): `world_from_object = world_from_local *
/// local_from_object`, with `world_from_local` a proper rotation and a translation and
/// `local_from_object = R^T L` (symmetric; negative determinant for a mirror).
pub fn split_rest_transform(world_from_object: Affine3A) -> (Affine3A, Mat3) {
    let l = Mat3::from(world_from_object.matrix3).as_dmat3();
    let det = l.determinant();
    if !det.is_finite() || det.abs() < 1e-300 {
        return (world_from_object, Mat3::IDENTITY);
    }
    // -L has the opposite determinant in 3D, so its orthogonal factor is a proper rotation.
    let mut r = if det < 0.0 { -l } else { l };
    for _ in 0..100 {
        let next = 0.5 * (r + r.inverse().transpose());
        let change: f64 = (next - r)
            .to_cols_array()
            .iter()
            .map(|x| x.abs())
            .fold(0.0, f64::max);
        r = next;
        if change < 1e-15 {
            break;
        }
    }
    let shape = r.transpose() * l;
    let rigid = Affine3A::from_mat3_translation(r.as_mat3(), world_from_object.translation.into());
    (rigid, shape.as_mat3())
}

/// Does `m` keep lengths (a rotation, possibly mirrored), within float precision?
pub(super) fn is_rigid(m: Mat3) -> bool {
    let e = m.transpose() * m - Mat3::IDENTITY;
    e.to_cols_array().iter().all(|x| x.abs() < 1e-5)
}

/// `object`'s mesh with `local_from_object` applied; a mirroring shape reverses the winding
/// so that the local cross products point to the front (glTF: front = object-frame CCW
/// side). Its attributes are only those the patches carry: `uvs[0]` the set the base-colour
/// texture reads, `uvs[1]` the emissive one's, the vertex colours and the lightmap's
/// coordinates.
pub(super) fn shape_mesh(object: &Object, local_from_object: Mat3) -> Mesh {
    let mesh = &object.mesh;
    let mirror = local_from_object.determinant() < 0.0;
    let material = &object.material;
    let set = |t: &Option<shrad_scene::Texture>| {
        t.as_ref()
            .and_then(|t| mesh.uvs.get(t.tex_coord as usize))
            .cloned()
            .unwrap_or_else(|| vec![Vec2::ZERO; mesh.positions.len()])
    };
    let uvs = if material.is_textured() {
        vec![
            set(&material.base_color_texture),
            set(&material.emissive_texture),
        ]
    } else {
        Vec::new()
    };
    Mesh {
        uvs,
        colors: mesh.colors.clone(),
        // Texture space: the same whatever the transform.
        lightmap_uvs: mesh.lightmap_uvs.clone(),
        positions: mesh
            .positions
            .iter()
            .map(|&p| local_from_object * p)
            .collect(),
        triangles: mesh
            .triangles
            .iter()
            .map(|&[a, b, c]| if mirror { [a, c, b] } else { [a, b, c] })
            .collect(),
    }
}

/// Every object's rest transform split, and its mesh in the local frame.
pub(super) type ShapedObject = (Affine3A, Mat3, Mesh);

pub(super) fn shaped_objects(scene: &Scene) -> Vec<ShapedObject> {
    scene
        .objects
        .iter()
        .map(|o| {
            let (world_from_local, local_from_object) = split_rest_transform(o.world_from_object);
            (
                world_from_local,
                local_from_object,
                shape_mesh(o, local_from_object),
            )
        })
        .collect()
}
