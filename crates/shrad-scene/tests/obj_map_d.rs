//! OBJ / MTL transparency (`obj_io/maps.rs`): a `map_d` cuts the surface in geometry as a
//! glTF `alphaMode: MASK` texture does (`cutout.rs`, cutoff 0.5), from the image's alpha
//! channel, or its luminance when it has none; `d 0` (or `Tr 1`) leaves an object out, a
//! partial `d` is opaque with a warning.
//!
//! The fixture is a unit quad "leaf" in the plane y = 0 whose texture coordinates are its
//! position (`vt x z` for `v x 0 z`), and a floor of another material, so that a scene is
//! left when the leaf is. The texture is 8 x 8 texels: a slot or band a whole number of
//! texels wide, the full length of the image, has straight edges on the subdivision lattice,
//! so what is kept is exactly the opaque texels' area.

use std::path::Path;

use glam::{Vec2, Vec3};
use shrad_scene::{load, LoadOptions, Object, Scene};

/// An 8 x 8 PNG at `path`: RGBA with alpha `alpha(x, y)` (x from the left, y from the top)
/// over a uniform green, or greyscale of value `alpha(x, y)` when `rgba` is false.
fn png(path: &Path, rgba: bool, alpha: impl Fn(u32, u32) -> u8) {
    let img = if rgba {
        let mut img = image::RgbaImage::new(8, 8);
        for (x, y, p) in img.enumerate_pixels_mut() {
            *p = image::Rgba([60, 160, 60, alpha(x, y)]);
        }
        image::DynamicImage::ImageRgba8(img)
    } else {
        let mut img = image::GrayImage::new(8, 8);
        for (x, y, p) in img.enumerate_pixels_mut() {
            *p = image::Luma([alpha(x, y)]);
        }
        image::DynamicImage::ImageLuma8(img)
    };
    img.save(path).unwrap();
}

/// Write `leaf.obj` (the leaf with material `leaf`, the floor with `floor`) and `leaf.mtl`
/// (`leaf_mtl` the body of material `leaf`) in a fresh folder `name`, and load it.
fn load_leaf(name: &str, leaf_mtl: &str, pngs: impl FnOnce(&Path)) -> Scene {
    let dir = crate::common::temp_dir(&format!("shrad-obj-map-d-{}-{name}", std::process::id()));
    pngs(&dir);
    std::fs::write(
        dir.join("leaf.mtl"),
        format!("newmtl leaf\n{leaf_mtl}\nnewmtl floor\nKd 0.5 0.5 0.5\n"),
    )
    .unwrap();
    let obj = "mtllib leaf.mtl\n\
        o leaf\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n\
        vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
        usemtl leaf\nf 1/1 4/4 3/3 2/2\n\
        o floor\nv -1 -1 -1\nv 2 -1 -1\nv 2 -1 2\nv -1 -1 2\n\
        usemtl floor\nf 5 8 7 6\n";
    let path = dir.join("leaf.obj");
    std::fs::write(&path, obj).unwrap();
    load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: refused: {e}"))
}

fn leaf(s: &Scene) -> Option<&Object> {
    s.objects.iter().find(|o| o.name == "leaf")
}

fn said(s: &Scene, part: &str) -> bool {
    s.warnings.iter().any(|w| w.contains(part))
}

/// The leaf's area and its triangles' centroids (x, z): the position, which is (u, v). Each
/// vertex's texture coordinates still match its position (v flipped, as shrad stores OBJ's).
fn coverage(o: &Object) -> (f32, Vec<Vec2>) {
    let m = &o.mesh;
    if let Some(uvs) = m.uvs.first() {
        for (p, uv) in m.positions.iter().zip(uvs) {
            assert!((uv.x - p.x).abs() < 1e-5 && (uv.y - (1.0 - p.z)).abs() < 1e-5);
        }
    }
    let area = (0..m.triangles.len()).map(|t| m.triangle_area(t)).sum();
    let centroids = m
        .triangles
        .iter()
        .map(|t| t.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / 3.0)
        .map(|c| Vec2::new(c.x, c.z))
        .collect();
    (area, centroids)
}

/// An RGBA `map_d` (the same image as `map_Kd`, as Blender writes a leaf) with two slots
/// of alpha 0 the height of the image, texel columns 2-3 and 6: what is left is the
/// opaque columns' area, 5/8, with no triangle in a slot; the colour texture is kept, and
/// a warning counts the triangles. The colour is uniform: the cut follows the alpha channel.
#[test]
fn an_alpha_map_with_slots_cuts_them_out() {
    let s = load_leaf(
        "slots",
        "Kd 0.8 0.8 0.8\nmap_Kd leaf.png\nmap_d leaf.png",
        |d| {
            png(&d.join("leaf.png"), true, |x, _| {
                if (2..4).contains(&x) || x == 6 {
                    0
                } else {
                    255
                }
            })
        },
    );
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    let (area, centroids) = coverage(o);
    assert!(
        (area - 5.0 / 8.0).abs() < 1e-4,
        "area {area}: {:?}",
        s.warnings
    );
    for c in centroids {
        let in_slot = (c.x > 2.0 / 8.0 && c.x < 4.0 / 8.0) || (c.x > 6.0 / 8.0 && c.x < 7.0 / 8.0);
        assert!(!in_slot, "a triangle kept in a slot, centroid {c}");
    }
    assert!(o.material.base_color_texture.is_some());
    let n = o.mesh.triangles.len();
    let cost = format!(
        "object 'leaf': material 'leaf' map_d 'leaf.png' cut-outs resolved to {n} triangle(s) from 2"
    );
    assert!(said(&s, &cost), "{:?}", s.warnings);
}

/// A greyscale `map_d` (no alpha channel) is read by its value: a black band of texel rows
/// 1-2 from the top of the image (OBJ's v from 5/8 to 7/8) is cut away, 6/8 is left and no
/// triangle in the band. Without `map_Kd` the leaf keeps no texture coordinates.
#[test]
fn a_greyscale_map_is_read_by_its_luminance() {
    let s = load_leaf("grey", "Kd 0.5 0.5 0.5\nmap_d -clamp off mask.png", |d| {
        png(&d.join("mask.png"), false, |_, y| {
            if (1..3).contains(&y) {
                0
            } else {
                255
            }
        })
    });
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    let (area, centroids) = coverage(o);
    assert!(
        (area - 6.0 / 8.0).abs() < 1e-4,
        "area {area}: {:?}",
        s.warnings
    );
    for c in centroids {
        assert!(
            !(c.y > 5.0 / 8.0 && c.y < 7.0 / 8.0),
            "a triangle kept in the band, centroid {c}"
        );
    }
    assert!(o.mesh.uvs.is_empty());
    assert!(
        said(&s, "map_d 'mask.png' cut-outs resolved to"),
        "{:?}",
        s.warnings
    );
}

/// A `map_d` naming a file that is not there: a warning naming it, and the leaf whole.
#[test]
fn a_missing_map_warns_and_the_leaf_stays_whole() {
    let s = load_leaf(
        "missing",
        "Kd 0.5 0.5 0.5\nmap_d -imfchan m gone.png",
        |_| {},
    );
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    assert_eq!(o.mesh.triangles.len(), 2);
    assert!((coverage(o).0 - 1.0).abs() < 1e-6);
    assert!(
        said(
            &s,
            "map_d 'gone.png' cannot be loaded (file not found); the material stays opaque"
        ),
        "{:?}",
        s.warnings
    );
}

/// A `map_d` naming a folder (here the OBJ's own) is named as not a regular file, not "not
/// found" (a device such as /dev/zero is refused the same way, never read).
#[test]
fn a_map_naming_a_folder_says_so() {
    let s = load_leaf("folder", "Kd 0.5 0.5 0.5\nmap_d .", |_| {});
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    assert!((coverage(o).0 - 1.0).abs() < 1e-6);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("map_d '.' cannot be loaded")
                && w.contains("is not a regular file (a folder or a device)")),
        "{:?}",
        s.warnings
    );
}

/// `d 0` (and `Tr 1`, its complement, without `d`) leaves the leaf out with a warning; a
/// partial `d 0.3` keeps it whole and opaque, with a warning; `d 1` says nothing; and `d 0`
/// beside a `map_d` is not read (Blender 2.7x wrote it so): the map decides.
#[test]
fn a_uniform_dissolve_leaves_out_only_what_is_fully_transparent() {
    for (name, mtl, said_as) in [("d0", "d 0", "d 0"), ("tr1", "Tr 1", "Tr 1")] {
        let s = load_leaf(name, &format!("Kd 0.5 0.5 0.5\n{mtl}"), |_| {});
        assert!(leaf(&s).is_none(), "{name}: {:?}", s.warnings);
        assert_eq!(s.objects.len(), 1, "{name}: the floor stays");
        let why = format!(
            "object 'leaf' skipped (it neither reflects nor blocks light): material 'leaf' is fully transparent ({said_as})"
        );
        assert!(said(&s, &why), "{name}: {:?}", s.warnings);
    }
    let s = load_leaf("partial", "Kd 0.5 0.5 0.5\nd 0.3", |_| {});
    assert_eq!(leaf(&s).map(|o| o.mesh.triangles.len()), Some(2));
    assert!(
        said(
            &s,
            "material 'leaf' is partly transparent (d 0.3): transparency is not represented, the surface is treated as opaque"
        ),
        "{:?}",
        s.warnings
    );
    let s = load_leaf("opaque", "Kd 0.5 0.5 0.5\nd 1", |_| {});
    assert_eq!(leaf(&s).map(|o| o.mesh.triangles.len()), Some(2));
    assert!(!said(&s, "transparent"), "{:?}", s.warnings);
    let s = load_leaf("d0-map", "Kd 0.5 0.5 0.5\nd 0\nmap_d half.png", |d| {
        png(
            &d.join("half.png"),
            true,
            |x, _| if x < 4 { 0 } else { 255 },
        )
    });
    let o = leaf(&s).unwrap_or_else(|| panic!("no leaf: {:?}", s.warnings));
    assert!((coverage(o).0 - 0.5).abs() < 1e-4, "{:?}", s.warnings);
}

/// Loaded through a scene file, an OBJ's warning names the file once: the scene file
/// prefixes its mesh files' warnings with their path, which the OBJ reader's carry already
/// ("leaf.obj: leaf.obj: map_d ..." before).
#[test]
fn a_scene_files_obj_warnings_name_the_file_once() {
    let dir = crate::common::temp_dir(&format!("shrad-obj-map-d-{}-scene", std::process::id()));
    std::fs::write(
        dir.join("leaf.mtl"),
        "newmtl leaf\nKd 0.5 0.5 0.5\nmap_d gone.png\n",
    )
    .unwrap();
    let obj = "mtllib leaf.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\n\
        vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl leaf\nf 1/1 4/4 3/3 2/2\n";
    std::fs::write(dir.join("leaf.obj"), obj).unwrap();
    let toml = "[[object]]\nname = \"leaf\"\nshape = \"mesh\"\nfile = \"leaf.obj\"\n\
        [[object]]\nname = \"lamp\"\nrole = \"light\"\nshape = \"quad\"\n\
        corners = [[0, 3, 0], [1, 3, 0], [1, 3, 1], [0, 3, 1]]\nemission = [1, 1, 1]\n";
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, toml).unwrap();
    let s = load(&scene, &LoadOptions::default()).unwrap();
    let w = s
        .warnings
        .iter()
        .find(|w| w.contains("gone.png"))
        .expect("the map_d warning");
    assert_eq!(w.matches("leaf.obj").count(), 1, "{w}");
}
