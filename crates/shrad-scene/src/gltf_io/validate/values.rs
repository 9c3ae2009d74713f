//! Warning-only rules (see `lint`) on the values of attributes shrad does not use or uses
//! only where a skin uses them: NORMAL and TANGENT (shrad computes face normals) and
//! JOINTS_n / WEIGHTS_n (read by `skin` for the meshes a skinned node draws, which refuses
//! what it cannot skin with: a joint beyond the skin with a weight, weights all zero; the
//! rest is warned of here, for every mesh). Every primitive of every mesh is checked, drawn or not, whatever its mode, as the
//! Khronos glTF-Validator checks them; one warning for each accessor and broken rule, with
//! how many elements break it and the first.
//!
//! Planned on the JSON once `unpack` has run ([`plan`]: which accessors, where, with which
//! skin), read once the gltf crate has the document ([`check`]) with the reader every
//! attribute of shrad is read with (`gltf::accessor::Iter`: each element bounds-checked
//! against its buffer view, sparse substitution applied), one pass over each accessor that
//! keeps a few counters and allocates nothing for its elements (so no size limit is needed
//! in front of it). Accessors whose values are not in the file are left out, as the
//! validator leaves them: implicit zeros (neither bufferView nor sparse), and the
//! primitives `unpack` marked as reading a buffer without data.

use std::collections::HashSet;

use gltf::accessor::{DataType, Dimensions, Item, Iter};
use gltf::mesh::util::ReadJoints;
use serde_json::Value;

use super::super::unpack::no_data;
use super::lint::primitives;

/// How far the length of a NORMAL, or of a TANGENT's XYZ, may be from 1: the
/// glTF-Validator's threshold (ACCESSOR_VECTOR3_NON_UNIT), a little more than the largest
/// error of a unit vector quantized to normalized signed bytes, which `KHR_mesh_quantization`
/// allows. glTF 2.0 says "normalized" and gives no tolerance; this one accepts every
/// quantized normal the specification allows and warns where the validator reports an error.
const UNIT_LENGTH_TOLERANCE: f64 = 0.00674;

/// How far a vertex's weights may sum from 1, for each two joints it uses beyond the first
/// two: the glTF-Validator's step (ACCESSOR_WEIGHTS_NON_NORMALIZED), a little more than the
/// error of one normalized unsigned byte (1/255). One or two weights must sum to exactly 1
/// (in single precision, as the validator sums them), three or four within one step, and so
/// on. glTF 2.0 ("Skins", "Skinned Mesh Attributes") asks float weights to sum "as close as
/// reasonably possible" to 1 and normalized integers to exactly 255 or 65535; the
/// validator's rule is the one files are checked against.
const WEIGHT_SUM_STEP: f64 = 0.0039216;

/// One check of [`plan`].
enum Check {
    /// NORMAL (VEC3) or TANGENT (VEC4) accessor `accessor` at `at`.
    Unit {
        at: String,
        accessor: usize,
        tangent: bool,
    },
    /// The influences of a primitive at `at` of `vertices` vertices: its (JOINTS_n,
    /// WEIGHTS_n) accessors, n = 0, 1, ..., and the fewest joints a skin of a node that
    /// draws the mesh has, with that skin (None when no node skins the mesh).
    Influences {
        at: String,
        sets: Vec<(usize, usize)>,
        vertices: usize,
        skin: Option<(usize, usize)>,
    },
}

/// The value checks of a file, from [`plan`], for [`check`].
pub(in crate::gltf_io) struct ValueChecks(Vec<Check>);

/// The fewest joints of a skin that a node drawing mesh `m` with it has: (count, skin).
fn smallest_skin(root: &Value, m: usize) -> Option<(usize, usize)> {
    let nodes = root["nodes"].as_array().into_iter().flatten();
    nodes
        .filter(|n| n["mesh"].as_u64() == Some(m as u64))
        .filter_map(|n| n["skin"].as_u64().map(|s| s as usize))
        .map(|s| (root["skins"][s]["joints"].as_array().map_or(0, Vec::len), s))
        .filter(|&(count, _)| count > 0)
        .min()
}

/// The checks of `root` (checked by `check_json`, unpacked): each NORMAL and TANGENT
/// accessor once, and each primitive's JOINTS_n / WEIGHTS_n; `zeros` are the accessors
/// whose values are implicit zeros, left out.
pub(in crate::gltf_io) fn plan(root: &Value, zeros: &[usize]) -> ValueChecks {
    let mut out = Vec::new();
    let mut seen_unit = HashSet::new();
    let mut seen_sets = HashSet::new();
    let in_file = |a: usize| !zeros.contains(&a);
    for (m, mesh) in root["meshes"].as_array().into_iter().flatten().enumerate() {
        for (p, prim) in primitives(mesh).iter().enumerate() {
            if no_data::skipped(prim).is_some() {
                continue;
            }
            let at = format!("meshes[{m}].primitives[{p}]");
            let attrs = &prim["attributes"];
            let get = |name: &str| attrs[name].as_u64().map(|a| a as usize);
            for (name, tangent) in [("NORMAL", false), ("TANGENT", true)] {
                if let Some(a) = get(name).filter(|&a| in_file(a) && seen_unit.insert(a)) {
                    out.push(Check::Unit {
                        at: format!("{at}.attributes.{name}"),
                        accessor: a,
                        tangent,
                    });
                }
            }
            let sets: Vec<(usize, usize)> = (0..)
                .map_while(|n| Some((get(&format!("JOINTS_{n}"))?, get(&format!("WEIGHTS_{n}"))?)))
                .collect();
            let vertices = get("POSITION").map(|a| root["accessors"][a]["count"].as_u64());
            let (Some(Some(vertices)), false) = (vertices, sets.is_empty()) else {
                continue;
            };
            let skin = smallest_skin(root, m);
            if sets.iter().all(|&(j, w)| in_file(j) && in_file(w))
                && seen_sets.insert((sets.clone(), skin))
            {
                out.push(Check::Influences {
                    at,
                    sets,
                    vertices: vertices as usize,
                    skin,
                });
            }
        }
    }
    ValueChecks(out)
}

/// The elements of an N-component accessor as f64 (normalized integers converted as glTF 2.0,
/// "Animations" and `KHR_mesh_quantization`, say). `skin` reads the weights it skins with so.
pub(in crate::gltf_io) enum Floats<'s, const N: usize>
where
    [f32; N]: Item,
    [i8; N]: Item,
    [u8; N]: Item,
    [i16; N]: Item,
    [u16; N]: Item,
{
    F32(Iter<'s, [f32; N]>),
    I8(Iter<'s, [i8; N]>),
    U8(Iter<'s, [u8; N]>),
    I16(Iter<'s, [i16; N]>),
    U16(Iter<'s, [u16; N]>),
}

impl<'s, const N: usize> Floats<'s, N>
where
    [f32; N]: Item,
    [i8; N]: Item,
    [u8; N]: Item,
    [i16; N]: Item,
    [u16; N]: Item,
{
    /// The reader of `acc` if it has N components, floats or normalized integers of a type
    /// `signed` allows (else the attribute-type lint has warned, and its values are not read).
    pub(in crate::gltf_io) fn new<'a, F>(
        acc: &gltf::Accessor<'a>,
        get: F,
        signed: bool,
    ) -> Option<Self>
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        if acc.dimensions().multiplicity() != N {
            return None;
        }
        let acc = acc.clone();
        Some(match (acc.data_type(), acc.normalized(), signed) {
            (DataType::F32, _, _) => Self::F32(Iter::new(acc, get)?),
            (DataType::I8, true, true) => Self::I8(Iter::new(acc, get)?),
            (DataType::I16, true, true) => Self::I16(Iter::new(acc, get)?),
            (DataType::U8, true, false) => Self::U8(Iter::new(acc, get)?),
            (DataType::U16, true, false) => Self::U16(Iter::new(acc, get)?),
            _ => return None,
        })
    }
}

impl<const N: usize> Iterator for Floats<'_, N>
where
    [f32; N]: Item,
    [i8; N]: Item,
    [u8; N]: Item,
    [i16; N]: Item,
    [u16; N]: Item,
{
    type Item = [f64; N];

    fn next(&mut self) -> Option<[f64; N]> {
        Some(match self {
            Self::F32(it) => it.next()?.map(f64::from),
            Self::I8(it) => it.next()?.map(|c| (f64::from(c) / 127.0).max(-1.0)),
            Self::I16(it) => it.next()?.map(|c| (f64::from(c) / 32767.0).max(-1.0)),
            Self::U8(it) => it.next()?.map(|c| f64::from(c) / 255.0),
            Self::U16(it) => it.next()?.map(|c| f64::from(c) / 65535.0),
        })
    }
}

/// The elements that break one rule: how many, and the first (its index and what it is).
struct Offenders<T> {
    count: usize,
    first: Option<(usize, T)>,
    last: Option<usize>,
}

impl<T> Default for Offenders<T> {
    fn default() -> Self {
        Self {
            count: 0,
            first: None,
            last: None,
        }
    }
}

impl<T> Offenders<T> {
    /// Element `k` breaks the rule (counted once however many of its components do).
    fn add(&mut self, k: usize, what: T) {
        if self.last != Some(k) {
            self.last = Some(k);
            self.count += 1;
            self.first.get_or_insert((k, what));
        }
    }
}

/// `at: what (glTF 2.0, section)`, as `JsonCheck::lint` words its warnings.
fn warn(warnings: &mut Vec<String>, at: &str, what: String, section: &str) {
    warnings.push(format!("{at}: {what} (glTF 2.0, {section})"));
}

/// Run the checks of `plan` on the document the gltf crate made of the file, with its
/// buffers; warnings are added.
pub(in crate::gltf_io) fn check(
    plan: &ValueChecks,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    warnings: &mut Vec<String>,
) {
    if plan.0.is_empty() {
        return;
    }
    let accessors: Vec<gltf::Accessor> = doc.accessors().collect();
    for c in &plan.0 {
        match c {
            Check::Unit {
                at,
                accessor,
                tangent,
            } => {
                if let Some(acc) = accessors.get(*accessor) {
                    unit_vectors(acc, buffers, at, *tangent, warnings);
                }
            }
            Check::Influences {
                at,
                sets,
                vertices,
                skin,
            } => influences(&accessors, buffers, at, sets, *vertices, *skin, warnings),
        }
    }
}

/// NORMAL: unit XYZ vectors; TANGENT: unit XYZ and a W of 1 or -1 (glTF 2.0, "Meshes").
fn unit_vectors(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    at: &str,
    tangent: bool,
    warnings: &mut Vec<String>,
) {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
    let mut length = Offenders::<f64>::default();
    let mut sign = Offenders::<f64>::default();
    let mut unit = |k: usize, v: [f64; 3]| {
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        // A NaN component counts as not unit.
        if (len - 1.0).abs() > UNIT_LENGTH_TOLERANCE || len.is_nan() {
            length.add(k, len);
        }
    };
    let n = acc.count();
    if tangent {
        let Some(it) = Floats::<4>::new(acc, get, true) else {
            return;
        };
        for (k, v) in it.enumerate() {
            unit(k, [v[0], v[1], v[2]]);
            if v[3] != 1.0 && v[3] != -1.0 {
                sign.add(k, v[3]);
            }
        }
    } else {
        let Some(it) = Floats::<3>::new(acc, get, true) else {
            return;
        };
        for (k, v) in it.enumerate() {
            unit(k, v);
        }
    }
    let (a, what) = (acc.index(), if tangent { "tangent" } else { "normal" });
    if let Some((k, len)) = length.first {
        let rule = if tangent {
            "the XYZ of a TANGENT is a unit vector"
        } else {
            "a NORMAL is a unit XYZ vector"
        };
        warn(
            warnings,
            at,
            format!(
                "accessor {a}: {} of {n} {what}s are not unit length (first: element {k}, length {len:.4}); {rule}",
                length.count
            ),
            "Meshes",
        );
    }
    if let Some((k, w)) = sign.first {
        warn(
            warnings,
            at,
            format!(
                "accessor {a}: {} of {n} tangents have a W that is neither 1 nor -1 (first: element {k}, W {w}); W is the handedness of the tangent basis, 1 or -1",
                sign.count
            ),
            "Meshes",
        );
    }
}

/// A primitive's skinning influences, every JOINTS_n / WEIGHTS_n set of a vertex together
/// (glTF 2.0, "Skins", "Skinned Mesh Attributes"): each joint index below the joint count of
/// the skin (the smallest, when several skin the mesh), no joint twice with a non-zero
/// weight, no negative weight, and the weights summing to 1 (see [`WEIGHT_SUM_STEP`]). A
/// joint index with a zero weight is left alone: it "should" be 0, a warning of the
/// validator, not an error. A set of another count than POSITION's or of a type glTF 2.0
/// does not allow (the lints warn of both) is not read.
fn influences(
    accessors: &[gltf::Accessor],
    buffers: &[gltf::buffer::Data],
    at: &str,
    sets: &[(usize, usize)],
    vertices: usize,
    skin: Option<(usize, usize)>,
    warnings: &mut Vec<String>,
) {
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
    let mut joints = Vec::with_capacity(sets.len());
    let mut weights = Vec::with_capacity(sets.len());
    for &(j, w) in sets {
        let (Some(ja), Some(wa)) = (accessors.get(j), accessors.get(w)) else {
            return;
        };
        if ja.count() != vertices || wa.count() != vertices {
            return;
        }
        if ja.dimensions() != Dimensions::Vec4 || ja.normalized() {
            return;
        }
        let read = match ja.data_type() {
            DataType::U8 => Iter::new(ja.clone(), get).map(ReadJoints::U8),
            DataType::U16 => Iter::new(ja.clone(), get).map(ReadJoints::U16),
            _ => None,
        };
        let (Some(read), Some(ws)) = (read, Floats::<4>::new(wa, get, false)) else {
            return;
        };
        joints.push(read.into_u16());
        weights.push(ws);
    }
    let n = sets.len();
    let mut found = Influences::new(n);
    let Influences {
        oob,
        twice,
        negative,
        sums,
    } = &mut found;
    let mut used: Vec<u16> = Vec::with_capacity(4 * n);
    let limit = skin.map(|s| s.0);
    'vertices: for k in 0..vertices {
        used.clear();
        let mut sum = 0f32;
        for s in 0..n {
            let (Some(js), Some(ws)) = (joints[s].next(), weights[s].next()) else {
                break 'vertices;
            };
            for c in 0..4 {
                let (j, w) = (js[c], ws[c]);
                if limit.is_some_and(|l| usize::from(j) >= l) {
                    oob[s].add(k, (c, j));
                    continue;
                }
                if w == 0.0 {
                    continue;
                }
                let unique = !used.contains(&j);
                if unique {
                    used.push(j);
                } else {
                    twice[s].add(k, (c, j));
                }
                if w < 0.0 {
                    negative[s].add(k, (c, w));
                } else if unique {
                    // In single precision, as the validator sums.
                    sum = (f64::from(sum) + w) as f32;
                }
            }
        }
        let tolerance = WEIGHT_SUM_STEP * (used.len().div_ceil(2) as f64 - 1.0);
        if (f64::from(sum) - 1.0).abs() > tolerance || sum.is_nan() {
            sums.add(k, sum);
        }
    }
    report_influences(&found, at, sets, vertices, skin, warnings);
}

/// What [`influences`] found wrong, per JOINTS_n / WEIGHTS_n set (the sums per vertex).
struct Influences {
    oob: Vec<Offenders<(usize, u16)>>,
    twice: Vec<Offenders<(usize, u16)>>,
    negative: Vec<Offenders<(usize, f64)>>,
    sums: Offenders<f32>,
}

impl Influences {
    fn new(sets: usize) -> Self {
        Influences {
            oob: (0..sets).map(|_| Offenders::default()).collect(),
            twice: (0..sets).map(|_| Offenders::default()).collect(),
            negative: (0..sets).map(|_| Offenders::default()).collect(),
            sums: Offenders::default(),
        }
    }
}

/// One warning per set and rule [`influences`] found broken.
fn report_influences(
    found: &Influences,
    at: &str,
    sets: &[(usize, usize)],
    vertices: usize,
    skin: Option<(usize, usize)>,
    warnings: &mut Vec<String>,
) {
    let Influences {
        oob,
        twice,
        negative,
        sums,
    } = found;
    let n = sets.len();
    for (s, &(j, w)) in sets.iter().enumerate() {
        let joints_at = format!("{at}.attributes.JOINTS_{s}");
        if let (Some((k, (c, joint))), Some((count, sk))) = (oob[s].first, skin) {
            let what = format!(
                "accessor {j}: {} of {vertices} vertices have a joint index not below the {count} joints of skins[{sk}], which skins this mesh (first: vertex {k}, component {c}, joint {joint})",
                oob[s].count
            );
            warn(warnings, &joints_at, what, "Skins");
        }
        if let Some((k, (c, joint))) = twice[s].first {
            let what = format!(
                "accessor {j}: {} of {vertices} vertices have a joint more than once with a non-zero weight (first: vertex {k}, component {c}, joint {joint})",
                twice[s].count
            );
            warn(warnings, &joints_at, what, "Skins");
        }
        if let Some((k, (c, weight))) = negative[s].first {
            let what = format!(
                "accessor {w}: {} of {vertices} vertices have a negative weight (first: vertex {k}, component {c}, weight {weight})",
                negative[s].count
            );
            warn(
                warnings,
                &format!("{at}.attributes.WEIGHTS_{s}"),
                what,
                "Skins",
            );
        }
    }
    if let Some((k, sum)) = sums.first {
        let names: Vec<String> = (0..n).map(|s| format!("WEIGHTS_{s}")).collect();
        let list: Vec<String> = sets.iter().map(|s| s.1.to_string()).collect();
        let what = format!(
            "{} of {vertices} vertices have weights ({}, accessor(s) {}) that do not sum to 1 (first: vertex {k}, sum {sum})",
            sums.count,
            names.join(" + "),
            list.join(", ")
        );
        warn(warnings, &format!("{at}.attributes"), what, "Skins");
    }
}
