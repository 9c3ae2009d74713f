//! Morph targets at rest (glTF 2.0, "Morph Targets"): a primitive's positions displaced by
//! its targets' POSITION accessors, each times its weight (the node's, else the mesh's).
//! An animation of the weights is not played (`anim` warns): the pose at rest is the shape.

use glam::Vec3;

use super::mesh::Place;
use super::walk::Walk;

impl Walk<'_> {
    /// Morph targets (glTF 2.0, "Morph Targets"): each target's POSITION displacements,
    /// times its weight in `weights` (missing weights are 0), added to `positions`. Target
    /// accessors are read as any accessor is (sparse substitution applied; integers, as
    /// `KHR_mesh_quantization` allows, converted and normalized as the accessor says).
    /// NORMAL and TANGENT displacements are not read: shrad computes face normals from the
    /// positions. A target that cannot be used is ignored with a warning; a morphed vertex
    /// that is not finite refuses the file, as a base one does.
    pub(super) fn morph(
        &mut self,
        prim: &gltf::Primitive,
        weights: &[f32],
        positions: &mut [Vec3],
        at: &Place,
    ) -> Result<(), String> {
        let (who, inst) = (&at.who, &at.inst);
        let buffers = self.buffers;
        let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
        let n = positions.len();
        let mut morphed = false;
        for (k, target) in prim.morph_targets().enumerate() {
            let w = weights.get(k).copied().unwrap_or(0.0);
            let Some(acc) = target.positions().filter(|_| w != 0.0) else {
                continue;
            };
            let here = format!("{who}.targets[{k}].POSITION{inst}");
            let why = if acc.count() != n {
                Some(format!(
                    "accessor {} has {} elements for {n} vertices",
                    acc.index(),
                    acc.count()
                ))
            } else {
                match read_vec3(&acc, get) {
                    None => Some(format!(
                        "accessor {} ({:?} {:?}{}) cannot be read as displacements",
                        acc.index(),
                        acc.dimensions(),
                        acc.data_type(),
                        if acc.normalized() { " normalized" } else { "" }
                    )),
                    Some(d) if d.len() != n => Some(format!(
                        "accessor {} has {} elements for {n} vertices",
                        acc.index(),
                        d.len()
                    )),
                    Some(d) => match d.iter().position(|v| !v.is_finite()) {
                        Some(e) => Some(format!(
                            "displacement {e} of accessor {} is not finite",
                            acc.index()
                        )),
                        None => {
                            for (p, d) in positions.iter_mut().zip(d) {
                                *p += w * d;
                            }
                            morphed = true;
                            None
                        }
                    },
                }
            };
            if let Some(why) = why {
                self.scene.warnings.push(format!(
                    "{here}: {why}: this morph target (weight {w}) is ignored"
                ));
            }
        }
        if morphed {
            if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
                return Err(format!(
                    "{who}.attributes.POSITION{inst}: vertex {k} is not finite once morphed by the weights {weights:?} ({})",
                    positions[k]
                ));
            }
        }
        Ok(())
    }
}

/// The VEC3 elements of accessor `acc` (whose count the caller checked to be above 0) as
/// floats: FLOAT, or integers (`KHR_mesh_quantization`: BYTE, UNSIGNED_BYTE, SHORT,
/// UNSIGNED_SHORT), normalized as glTF 2.0 ("Accessors") says when the accessor is; sparse
/// substitution applied (the gltf crate's accessor iterator). None when the accessor is of
/// another type or its data cannot be read.
fn read_vec3<'a, 's, F>(acc: &gltf::Accessor<'a>, get: F) -> Option<Vec<Vec3>>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    use gltf::accessor::{DataType, Dimensions, Iter};
    if acc.dimensions() != Dimensions::Vec3 || acc.count() == 0 {
        return None;
    }
    let norm = acc.normalized();
    macro_rules! ints {
        ($t:ty, $max:expr) => {
            Iter::<[$t; 3]>::new(acc.clone(), get)?
                .map(|v| {
                    Vec3::from(v.map(|c| {
                        let x = f32::from(c);
                        if norm {
                            (x / $max).max(-1.0)
                        } else {
                            x
                        }
                    }))
                })
                .collect()
        };
    }
    Some(match acc.data_type() {
        DataType::F32 => Iter::<[f32; 3]>::new(acc.clone(), get)?
            .map(Vec3::from)
            .collect(),
        DataType::I8 => ints!(i8, 127.0),
        DataType::U8 => ints!(u8, 255.0),
        DataType::I16 => ints!(i16, 32767.0),
        DataType::U16 => ints!(u16, 65535.0),
        DataType::U32 => return None,
    })
}
