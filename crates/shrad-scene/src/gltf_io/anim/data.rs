//! The accessor data of glTF animations: key times and values as floats, and the element
//! types a channel accepts.

use gltf::accessor::{DataType, Dimensions};

use super::Path;

/// The float components of accessor `index` (`dims` per element), normalised integers
/// converted as the specification says; all zeros for an accessor without data.
pub(super) fn read_floats(
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    index: usize,
    at: &str,
) -> Result<(Vec<f32>, usize), String> {
    let acc = doc
        .accessors()
        .nth(index)
        .ok_or_else(|| format!("{at}: accessor {index} does not exist"))?;
    let dims = acc.dimensions().multiplicity();
    let count = acc.count();
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
    let unreadable = || format!("{at}: accessor {index} cannot be read");
    macro_rules! read {
        ($t:ty, $conv:expr) => {{
            match gltf::accessor::Iter::<$t>::new(acc.clone(), get) {
                Some(it) => {
                    let v: Vec<f32> = it.flat_map($conv).collect();
                    if v.len() != count * dims {
                        return Err(unreadable());
                    }
                    v
                }
                None if acc.view().is_none() && acc.sparse().is_none() => vec![0.0; count * dims],
                None => return Err(unreadable()),
            }
        }};
    }
    let norm = acc.normalized();
    let data = match (acc.dimensions(), acc.data_type(), norm) {
        (Dimensions::Scalar, DataType::F32, _) => read!(f32, |x: f32| [x]),
        (Dimensions::Vec3, DataType::F32, _) => read!([f32; 3], |x: [f32; 3]| x),
        (Dimensions::Vec4, DataType::F32, _) => read!([f32; 4], |x: [f32; 4]| x),
        (Dimensions::Vec4, DataType::I8, true) => read!([i8; 4], |x: [i8; 4]| x
            .map(|c| (f32::from(c) / 127.0).max(-1.0))),
        (Dimensions::Vec4, DataType::U8, true) => {
            read!([u8; 4], |x: [u8; 4]| x.map(|c| f32::from(c) / 255.0))
        }
        (Dimensions::Vec4, DataType::I16, true) => read!([i16; 4], |x: [i16; 4]| x
            .map(|c| (f32::from(c) / 32767.0).max(-1.0))),
        (Dimensions::Vec4, DataType::U16, true) => {
            read!([u16; 4], |x: [u16; 4]| x.map(|c| f32::from(c) / 65535.0))
        }
        _ => return Err(format!("{at}: accessor {index} has an unsupported type")),
    };
    Ok((data, dims))
}

/// Describe an accessor's element type for messages ("VEC3 FLOAT").
pub(super) fn describe(acc: &gltf::Accessor) -> String {
    format!(
        "{:?}{} {:?}",
        acc.dimensions(),
        if acc.normalized() { " normalized" } else { "" },
        acc.data_type()
    )
    .to_uppercase()
}

/// Can accessor `out` hold the values of a `path` channel?
pub(super) fn output_type_fits(out: &gltf::Accessor, path: Path) -> bool {
    let float = out.data_type() == DataType::F32 && !out.normalized();
    match path {
        Path::Translation | Path::Scale | Path::LightColor | Path::EmissiveFactor => {
            out.dimensions() == Dimensions::Vec3 && float
        }
        Path::LightIntensity
        | Path::LightRange
        | Path::SpotInner
        | Path::SpotOuter
        | Path::EmissiveStrength
        | Path::CameraYfov => out.dimensions() == Dimensions::Scalar && float,
        Path::BaseColorFactor => out.dimensions() == Dimensions::Vec4 && float,
        Path::Rotation => {
            out.dimensions() == Dimensions::Vec4
                && (out.data_type() == DataType::F32
                    || (out.normalized()
                        && matches!(
                            out.data_type(),
                            DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16
                        )))
        }
    }
}
