//! Quantized and compressed meshes, as the glTF ecosystem's two optimisers write them, load
//! as the file they were made from: `scenes/cornell.gltf` rewritten by
//!
//! - `gltfpack -kn -km -ke` (1.3, npm): `KHR_mesh_quantization` (UNSIGNED_SHORT positions,
//!   a dequantizing parent node) → `cornell-quant.glb`;
//! - the same with `-c -ce ext` and `-cc -ce ext`: plus `EXT_meshopt_compression` →
//!   `cornell-meshopt.glb`, `cornell-meshopt-cc.glb`; with `-cc -ce khr`:
//!   `KHR_meshopt_compression` (version 1 attribute streams) → `cornell-meshopt-khr-cc.glb`;
//! - `gltf-pipeline -d` (4.3, npm): `KHR_draco_mesh_compression` → `cornell-draco.glb`, and
//!   with `-s` (separate .bin) → `cornell-draco-gltf/`.
//!
//! And a scene with more kinds of data (`rich.py`: smooth normals, UVs, 16-bit colours, a
//! quaternion animation) rewritten by gltfpack with `-ce ext` and `-ce khr` (also with
//! `-noq` and `-vpf`): the version 1 streams must load exactly as the version 0 streams of the
//! same quantized data.
//!
//! Each object keeps its name, triangle count, material and emission, and its world-space
//! area and bounds within what quantization allows (gltfpack's 14-bit positions and
//! gltf-pipeline's 11-bit ones move a vertex by at most half a step of the scene's extent
//! over 2^bits). The renders are compared in docs/results.md ("Compressed glTF").

use std::path::{Path, PathBuf};

use glam::Vec3;
use shrad_scene::{load, LoadOptions, Scene};

mod common;

use common::panics::{count_panics, panics};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/compressed")
        .join(name)
}

fn original() -> Scene {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell.gltf");
    load(&p, &LoadOptions::default()).unwrap()
}

/// World-space area of every triangle of object `o` of `s`.
fn area(s: &Scene, o: usize) -> f32 {
    let ob = &s.objects[o];
    ob.mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| {
                ob.world_from_object
                    .transform_point3(ob.mesh.positions[i as usize])
            });
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum()
}

fn world_bounds(s: &Scene, o: usize) -> (Vec3, Vec3) {
    let ob = &s.objects[o];
    ob.mesh.positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| {
            let p = ob.world_from_object.transform_point3(p);
            (lo.min(p), hi.max(p))
        },
    )
}

/// `file` loads as the original, within `bits` of position quantization.
fn matches_original(file: &str, bits: u32) {
    let a = original();
    let b = load(&data(file), &LoadOptions::default()).unwrap_or_else(|e| panic!("{file}: {e}"));
    assert_eq!(a.objects.len(), b.objects.len(), "{file}: object count");
    let (lo, hi) = a.bounds().map(|b| (b.min, b.max)).unwrap();
    let step = (hi - lo).max_element() / (1u32 << bits) as f32;
    for (i, oa) in a.objects.iter().enumerate() {
        // gltfpack moves each mesh to an unnamed child of its named node (the child holds
        // the dequantizing transform): the object takes its parent's name and roles.
        let j = b
            .objects
            .iter()
            .position(|o| o.name == oa.name)
            .unwrap_or_else(|| panic!("{file}: no object named {}", oa.name));
        let ob = &b.objects[j];
        assert_eq!(oa.role, ob.role, "{file}: {} role", oa.name);
        assert_eq!(
            oa.mesh.triangles.len(),
            ob.mesh.triangles.len(),
            "{file}: {} triangles",
            oa.name
        );
        assert!(
            oa.material
                .reflectance
                .abs_diff_eq(ob.material.reflectance, 1e-6),
            "{file}: {} reflectance",
            oa.name
        );
        assert!(
            oa.material
                .emitted_radiance
                .abs_diff_eq(ob.material.emitted_radiance, 1e-4),
            "{file}: {} emission",
            oa.name
        );
        let (la, ha) = world_bounds(&a, i);
        let (lb, hb) = world_bounds(&b, j);
        assert!(
            la.abs_diff_eq(lb, step) && ha.abs_diff_eq(hb, step),
            "{file}: {} bounds {la}..{ha} vs {lb}..{hb} (step {step})",
            oa.name
        );
        let (aa, ab) = (area(&a, i), area(&b, j));
        assert!(
            (aa - ab).abs() <= 1e-3 * aa,
            "{file}: {} area {aa} vs {ab}",
            oa.name
        );
    }
}

#[test]
fn gltfpack_quantized() {
    matches_original("cornell-quant.glb", 14);
}

#[test]
fn gltfpack_meshopt() {
    matches_original("cornell-meshopt.glb", 14);
    matches_original("cornell-meshopt-cc.glb", 14);
    matches_original("cornell-meshopt-khr-cc.glb", 14);
}

/// gltfpack's `KHR_meshopt_compression` files (version 1 attribute codec: control and
/// channel modes, COLOR filter; before, refused as an extension shrad does not implement)
/// load exactly as its `EXT_meshopt_compression` files of the same data (version 0, decoded
/// by meshopt-rs): every position, triangle, UV and animated pose equal to the bit; the
/// colours within the COLOR filter's precision (only KHR has the filter).
#[test]
fn khr_meshopt_loads_exactly_as_ext_meshopt() {
    for variant in ["cc", "noq", "vpf"] {
        let ext = load(
            &data(&format!("rich-{variant}-ext.glb")),
            &LoadOptions::default(),
        )
        .unwrap();
        let khr = load(
            &data(&format!("rich-{variant}-khr.glb")),
            &LoadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{variant}: {e}"));
        assert_eq!(ext.objects.len(), khr.objects.len(), "{variant}");
        for (a, b) in ext.objects.iter().zip(&khr.objects) {
            let at = format!("{variant}: {}", a.name);
            assert_eq!(a.name, b.name, "{at}");
            assert!(!a.mesh.positions.is_empty(), "{at}");
            let (ma, mb) = (&a.mesh, &b.mesh);
            assert!(ma.positions == mb.positions, "{at}: positions differ");
            assert!(ma.triangles == mb.triangles, "{at}: triangles differ");
            assert!(ma.uvs == mb.uvs, "{at}: texture coordinates differ");
            // Colours: EXT has no COLOR filter, so gltfpack stores them plainly there and in
            // YCoCg under KHR's filter (lossy: measured within one step of 8 bits, 3.9e-3).
            assert_eq!(ma.colors.len(), mb.colors.len(), "{at}: colours");
            let worst = (ma.colors.iter().zip(&mb.colors))
                .map(|(x, y)| (*x - *y).abs().max_element())
                .fold(0.0, f32::max);
            eprintln!("{at}: colours within {worst:.1e}");
            assert!(worst < 5e-3, "{at}: colours differ by {worst}");
            assert_eq!(a.material, b.material, "{at}: material");
            for t in [0.0, 0.3, 1.0, 1.7] {
                assert_eq!(
                    a.world_from_object_at(t),
                    b.world_from_object_at(t),
                    "{at} at {t}"
                );
            }
        }
        let ring = khr.objects.iter().find(|o| o.name == "Ring").unwrap();
        assert!(
            ring.is_animated() && !ring.mesh.colors.is_empty(),
            "{variant}: the ring"
        );
    }
}

#[test]
fn gltf_pipeline_draco() {
    matches_original("cornell-draco.glb", 11);
    matches_original("cornell-draco-gltf/cornell-draco.gltf", 11);
}

/// Every byte of each compressed file's BIN chunk (the meshopt and Draco streams) flipped in
/// turn: each load is an error or a scene, never a panic (a hook counts panics even where the
/// reader's guard catches them), except inside draco-oxide-decoder, whose panics on a corrupt
/// stream the Draco step catches and reports as a malformed stream; they are counted apart.
#[test]
fn corrupt_streams_never_panic() {
    count_panics();
    let dir = std::env::temp_dir().join(format!("shrad-compressed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut loads = 0;
    for file in [
        "cornell-meshopt.glb",
        "cornell-meshopt-cc.glb",
        "cornell-meshopt-khr-cc.glb",
        "cornell-draco.glb",
    ] {
        let bytes = std::fs::read(data(file)).unwrap();
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let bin = 20 + json_len + 8;
        let p = dir.join(file);
        let mut try_load = |b: &[u8]| {
            std::fs::write(&p, b).unwrap();
            let before = panics().outside_draco;
            let _ = load(&p, &LoadOptions::default());
            assert_eq!(
                panics().outside_draco,
                before,
                "{file}: a corrupt stream panicked"
            );
            loads += 1;
        };
        for i in bin..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0xA5;
            try_load(&b);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    let draco = panics().in_draco;
    println!(
        "{loads} corrupt loads, 0 panics in shrad, {draco} inside draco-oxide-decoder (caught: an error)"
    );
}
