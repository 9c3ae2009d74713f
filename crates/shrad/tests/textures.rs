//! Textures and vertex colours (spec section 2, "Textures"): glTF and OBJ import, per-patch
//! reflectance as the area average over each patch's footprint, wrap modes and
//! `KHR_texture_transform`, and pictures that show the texture at full detail.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Vec2, Vec3};
use serde_json::{json, Value};
use shrad::reference::{solve, ReferenceOptions};
use shrad::render::{render, RenderOptions, Shading};
use shrad::scene::{srgb_to_linear, Camera, LoadOptions};
use shrad::vis::Backend;
use shrad::{NoProgress, PatchSizing, World};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-textures-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// An `n x n` checker PNG of 8-bit sRGB values `light` (texel (0, 0)) and `dark`.
fn checker_png(path: &Path, n: u32, light: u8, dark: u8) {
    let img = image::RgbImage::from_fn(n, n, |x, y| {
        image::Rgb([if (x + y) % 2 == 0 { light } else { dark }; 3])
    });
    img.save(path).unwrap();
}

/// The unit floor quad `x, z in [0, 1]`, `y = 0`, facing +Y, `uv = scale * (x, z)`.
const FLOOR: [[f32; 3]; 4] = [[0., 0., 0.], [0., 0., 1.], [1., 0., 1.], [1., 0., 0.]];

/// A glTF with the floor (texture coordinates `uv_scale * (x, z)`, optional `COLOR_0`) using
/// material 0, and a light quad at `y = 1` facing down; `edit` fills in materials, images,
/// textures and samplers. Buffers go to a `.bin` beside it.
fn floor_gltf(
    dir: &Path,
    name: &str,
    uv_scale: f32,
    color: Option<[f32; 3]>,
    edit: impl FnOnce(&mut Value),
) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    let mut put = |xs: &[f32]| {
        let off = bin.len();
        for x in xs {
            bin.extend_from_slice(&x.to_le_bytes());
        }
        off
    };
    let floor: Vec<f32> = FLOOR.iter().flatten().copied().collect();
    let uvs: Vec<f32> = FLOOR
        .iter()
        .flat_map(|p| [uv_scale * p[0], uv_scale * p[2]])
        .collect();
    let light: Vec<f32> = [
        [0.3, 1., 0.3],
        [0.7, 1., 0.3],
        [0.7, 1., 0.7],
        [0.3, 1., 0.7],
    ]
    .iter()
    .flatten()
    .copied()
    .collect();
    let o_floor = put(&floor);
    let o_uv = put(&uvs);
    let o_light = put(&light);
    let o_col = color.map(|c| put(&[c, c, c, c].concat()));
    let o_idx = bin.len();
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    let view = |off: usize, len: usize| json!({"buffer": 0, "byteOffset": off, "byteLength": len});
    let mut views = vec![
        view(o_floor, 48),
        view(o_uv, 32),
        view(o_light, 48),
        view(o_idx, 12),
    ];
    let vec3 = |v: usize, lo: [f32; 3], hi: [f32; 3]| json!({"bufferView": v, "componentType": 5126, "count": 4, "type": "VEC3", "min": lo, "max": hi});
    let mut accessors = vec![
        vec3(0, [0., 0., 0.], [1., 0., 1.]),
        json!({"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}),
        vec3(2, [0.3, 1., 0.3], [0.7, 1., 0.7]),
        json!({"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}),
    ];
    let mut attributes = json!({"POSITION": 0, "TEXCOORD_0": 1});
    if let Some(o) = o_col {
        views.push(view(o, 48));
        accessors.push(json!({"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC3"}));
        attributes["COLOR_0"] = json!(4);
    }
    let mut root = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "floor", "mesh": 0, "extras": {"shrad_role": "boundary"}},
            {"name": "light", "mesh": 1, "extras": {"shrad_role": "light"}}
        ],
        "meshes": [
            {"primitives": [{"attributes": attributes, "indices": 3, "material": 0}]},
            // The light faces down: reversed winding.
            {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "material": 1}]}
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]},
             "emissiveFactor": [1.0, 1.0, 1.0]}
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}]
    });
    edit(&mut root);
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
    path
}

/// The floor's material 0 with a base-colour texture of image `tex.png`.
fn textured(root: &mut Value, sampler: Value, texture_info: Value) {
    root["images"] = json!([{"uri": "tex.png"}]);
    root["samplers"] = json!([sampler]);
    root["textures"] = json!([{"source": 0, "sampler": 0}]);
    root["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = texture_info;
}

const NEAREST: i32 = 9728;

fn load_world(path: &Path, patch: f32) -> World {
    let scene = shrad::scene::load(path, &LoadOptions::default()).unwrap();
    World::new(scene, PatchSizing::Size(patch), Backend::Auto).unwrap()
}

/// `(x range, z range)` of floor patch `p` (object 0, identity transform: u = x, v = z).
fn footprint(world: &World, p: usize) -> ([f32; 2], [f32; 2]) {
    let c = world.patches.corners[p];
    let xs = c.map(|c| c.x);
    let zs = c.map(|c| c.z);
    let lo = |a: [f32; 4]| a.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = |a: [f32; 4]| a.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    ([lo(xs), hi(xs)], [lo(zs), hi(zs)])
}

/// The exact mean over the rectangle `[u0, u1] x [v0, v1]` of an `n x n` nearest-texel
/// checker with values `light` (texel (0, 0)) and `dark`, repeated with period 1.
fn checker_mean(n: u32, light: f32, dark: f32, u: [f32; 2], v: [f32; 2]) -> f32 {
    let n = n as f32;
    let overlap = |a: [f32; 2], i: f32| ((a[1] * n).min(i + 1.0) - (a[0] * n).max(i)).max(0.0);
    let mut sum = 0.0;
    let (i0, i1) = ((u[0] * n).floor() as i32, (u[1] * n).ceil() as i32);
    let (j0, j1) = ((v[0] * n).floor() as i32, (v[1] * n).ceil() as i32);
    for j in j0..j1 {
        for i in i0..i1 {
            let w = overlap(u, i as f32) * overlap(v, j as f32);
            sum += w * if (i + j).rem_euclid(2) == 0 {
                light
            } else {
                dark
            };
        }
    }
    sum / ((u[1] - u[0]) * (v[1] - v[0]) * n * n)
}

#[test]
fn patch_reflectance_is_the_texture_mean_over_its_footprint() {
    let dir = temp_dir("footprint");
    checker_png(&dir.join("tex.png"), 4, 255, 64);
    let path = floor_gltf(&dir, "floor", 1.0, None, |r| {
        textured(r, json!({"magFilter": NEAREST}), json!({"index": 0}))
    });
    // 5 x 5 patches of 0.8 x 0.8 texels: texel edges cut patches.
    let world = load_world(&path, 0.2);
    let (light, dark) = (0.8 * 1.0, 0.8 * srgb_to_linear(64.0 / 255.0));
    let floor = world.patches.range(0);
    assert_eq!(floor.len(), 25);
    let mut worst = 0f32;
    let mut distinct = Vec::new();
    for p in floor.clone() {
        let (u, v) = footprint(&world, p);
        let want = checker_mean(4, light, dark, u, v);
        let got = world.reflectance[p];
        worst = worst.max((got.x - want).abs() / light);
        assert!((got.x - got.z).abs() < 1e-6);
        distinct.push(want);
    }
    // Midpoint supersampling places a texel edge to 1/k of the patch (k = 32 here).
    assert!(worst < 0.02, "worst error {worst} of the light value");
    // The patches differ from one another, and are not the whole-texture mean.
    let spread =
        distinct.iter().copied().fold(0.0, f32::max) - distinct.iter().copied().fold(1.0, f32::min);
    assert!(spread > 0.3, "spread {spread}");
    // The whole quad's area average is the image's mean.
    let area: f32 = floor.clone().map(|p| world.patches.area[p]).sum();
    let mean: f32 = floor
        .clone()
        .map(|p| world.reflectance[p].x * world.patches.area[p])
        .sum::<f32>()
        / area;
    let image_mean = 0.5 * (light + dark);
    assert!(
        (mean - image_mean).abs() < 0.005 * image_mean,
        "{mean} vs {image_mean}"
    );
    // With bilinear filtering (the default) too: over whole periods it keeps the mean.
    let path = floor_gltf(&dir, "linear", 1.0, None, |r| {
        textured(r, json!({}), json!({"index": 0}))
    });
    let world = load_world(&path, 0.2);
    let mean: f32 = floor
        .clone()
        .map(|p| world.reflectance[p].x * world.patches.area[p])
        .sum::<f32>()
        / area;
    assert!(
        (mean - image_mean).abs() < 0.01 * image_mean,
        "{mean} vs {image_mean}"
    );
}

/// Reflectance of the floor's patches along x (z in the first row), left to right.
fn row(world: &World) -> Vec<f32> {
    let mut r: Vec<(f32, f32)> = world
        .patches
        .range(0)
        .filter(|&p| footprint(world, p).1[0] < 1e-6)
        .map(|p| (world.patches.centre[p].x, world.reflectance[p].x))
        .collect();
    r.sort_by(|a, b| a.0.total_cmp(&b.0));
    r.into_iter().map(|(_, rho)| rho).collect()
}

#[test]
fn wrap_modes_and_texture_transform_change_what_is_sampled() {
    let dir = temp_dir("wrap");
    // 2 x 2 checker: (0, 0) white, (1, 0) black.
    checker_png(&dir.join("tex.png"), 2, 255, 0);
    let (w, k) = (0.8, 0.0);
    let cases: [(&str, f32, Value, Value, [f32; 4]); 5] = [
        // REPEAT over u in [0, 2]: the pattern twice.
        ("repeat", 2.0, json!({}), json!({}), [w, k, w, k]),
        (
            "clamp",
            2.0,
            json!({"wrapS": 33071}),
            json!({}),
            [w, k, k, k],
        ),
        (
            "mirror",
            2.0,
            json!({"wrapS": 33648}),
            json!({}),
            [w, k, k, w],
        ),
        // Half an image's offset swaps the squares.
        (
            "offset",
            1.0,
            json!({}),
            json!({"offset": [0.5, 0.0]}),
            [k, k, w, w],
        ),
        // Scale 2 is REPEAT over [0, 2] again.
        (
            "scale",
            1.0,
            json!({}),
            json!({"scale": [2.0, 2.0]}),
            [w, k, w, k],
        ),
    ];
    for (name, uv_scale, sampler, transform, want) in cases {
        let mut sampler = sampler;
        sampler["magFilter"] = json!(NEAREST);
        let mut info = json!({"index": 0});
        if transform != json!({}) {
            info["extensions"] = json!({"KHR_texture_transform": transform});
        }
        let path = floor_gltf(&dir, name, uv_scale, None, |r| {
            r["extensionsUsed"] = json!(["KHR_texture_transform"]);
            textured(r, sampler, info)
        });
        // 4 x 4 patches: at u in [0, 2] each is half a texel wide, at [0, 1] a quarter.
        let world = load_world(&path, 0.25);
        let got = row(&world);
        let want: Vec<f32> = if uv_scale == 2.0 || name == "scale" {
            want.to_vec()
        } else {
            // Over [0, 1] with a half-image offset: texel 1 then texel 0 (2 patches each).
            want.to_vec()
        };
        assert_eq!(got.len(), 4, "{name}");
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-3, "{name}: {got:?} vs {want:?}");
        }
    }
}

#[test]
fn vertex_colours_multiply_the_factor() {
    let dir = temp_dir("colour");
    let path = floor_gltf(&dir, "floor", 1.0, Some([0.5, 1.0, 0.25]), |_| {});
    let scene = shrad::scene::load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(scene.objects[0].mesh.colors.len(), 4);
    let world = World::new(scene, PatchSizing::Size(0.25), Backend::Auto).unwrap();
    for p in world.patches.range(0) {
        assert!(
            world.reflectance[p].abs_diff_eq(Vec3::new(0.4, 0.8, 0.2), 1e-5),
            "{}",
            world.reflectance[p]
        );
    }
}

#[test]
fn one_image_is_decoded_once_for_two_materials() {
    let dir = temp_dir("shared");
    checker_png(&dir.join("tex.png"), 2, 255, 0);
    let path = floor_gltf(&dir, "floor", 1.0, None, |r| {
        textured(r, json!({}), json!({"index": 0}));
        // The light uses the same texture as its emissive texture, and a second texture
        // object names the same image.
        r["textures"] = json!([{"source": 0, "sampler": 0}, {"source": 0}]);
        r["materials"][1]["emissiveTexture"] = json!({"index": 1});
        r["meshes"][1]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(1);
    });
    let scene = shrad::scene::load(&path, &LoadOptions::default()).unwrap();
    let a = scene.objects[0]
        .material
        .base_color_texture
        .as_ref()
        .unwrap();
    let b = scene.objects[1].material.emissive_texture.as_ref().unwrap();
    assert!(Arc::ptr_eq(&a.image, &b.image));
    assert_eq!(b.wrap_s, shrad::scene::Wrap::Repeat);
    // The light's exitance follows its emissive texture, patch by patch.
    let world = World::new(scene, PatchSizing::Size(0.1), Backend::Auto).unwrap();
    let light = world.patches.range(1);
    let (lo, hi) = light.fold((f32::INFINITY, 0f32), |(lo, hi), p| {
        (lo.min(world.exitance[p].x), hi.max(world.exitance[p].x))
    });
    assert!(hi > 1.3 * lo, "light exitance {lo} .. {hi}");
}

/// The pixel a world point lands on.
fn pixel_of(camera: &Camera, w: u32, h: u32, p: Vec3) -> (u32, u32) {
    let c = camera.world_from_camera.inverse().transform_point3(p);
    let tan = (0.5 * camera.yfov).tan();
    let aspect = w as f32 / h as f32;
    let (x, y) = (c.x / -c.z / (tan * aspect), c.y / -c.z / tan);
    (
        ((x + 1.0) * 0.5 * w as f32) as u32,
        ((1.0 - y) * 0.5 * h as f32) as u32,
    )
}

#[test]
fn pictures_show_the_texture_at_full_detail() {
    let dir = temp_dir("render");
    // 2 x 2 checker on coarse patches (one patch per quarter would hide nothing; use 2 x 2
    // patches each covering... one texel) and a finer check: 8 x 8 texels on 2 x 2 patches.
    checker_png(&dir.join("tex.png"), 8, 255, 64);
    let path = floor_gltf(&dir, "floor", 1.0, None, |r| {
        textured(r, json!({"magFilter": NEAREST}), json!({"index": 0}))
    });
    let world = load_world(&path, 0.5);
    assert_eq!(world.patches.range(0).len(), 4);
    let camera = Camera::look_at(Vec3::new(0.5, 0.9, 0.5), Vec3::new(0.5, 0.0, 0.5), 1.2);
    let options = RenderOptions {
        width: 64,
        height: 64,
        spp: 1,
        shading: Shading::Smooth,
    };
    let ratio = 1.0 / srgb_to_linear(64.0 / 255.0);
    // Uniform irradiance 1 on every patch: each pixel is rho(x) / pi.
    let b: Vec<Vec3> = (0..world.patches.len())
        .map(|p| world.reflectance[p] + world.exitance[p])
        .collect();
    let image = render(&world, &b, &camera, &options);
    let at = |u: f32, v: f32, image: &shrad::render::Image| {
        let (x, y) = pixel_of(&camera, 64, 64, Vec3::new(u, 0.0, v));
        image.pixels[(y * 64 + x) as usize].x
    };
    // Texel (2, 3) is dark, (3, 3) light: inside one patch, 8 texels across 4 patches.
    let (texel_dark, texel_light) = (
        at(2.5 / 8.0, 3.5 / 8.0, &image),
        at(3.5 / 8.0, 3.5 / 8.0, &image),
    );
    let pi = std::f32::consts::PI;
    assert!((texel_light - 0.8 / pi).abs() < 1e-4, "{texel_light}");
    assert!(
        (texel_light / texel_dark - ratio).abs() < 0.01 * ratio,
        "{texel_light} / {texel_dark} vs {ratio}"
    );
    // Lit by the reference solver: two texels mirror-symmetric about the light's axis see
    // the same irradiance, so their pixels differ by the albedo ratio.
    let (radiosity, stats) = solve(&world, &ReferenceOptions::standard(), &NoProgress);
    assert!(stats.converged);
    let image = render(&world, &radiosity, &camera, &options);
    let (l, d) = (
        at(3.5 / 8.0, 3.5 / 8.0, &image),
        at(4.5 / 8.0, 3.5 / 8.0, &image),
    );
    assert!(l > 0.0 && d > 0.0);
    assert!((l / d - ratio).abs() < 0.03 * ratio, "{l} / {d} vs {ratio}");
}

#[test]
fn obj_map_kd_loads() {
    let dir = temp_dir("obj");
    checker_png(&dir.join("tex.png"), 2, 255, 0);
    std::fs::write(
        dir.join("floor.mtl"),
        "newmtl floor\nKd 0.8 0.8 0.8\nmap_Kd tex.png\n",
    )
    .unwrap();
    // OBJ's v grows upwards: v = 1 - z here makes uv = (x, z) in glTF's convention.
    std::fs::write(
        dir.join("floor.obj"),
        "mtllib floor.mtl\no floor\nv 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\n\
         vt 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl floor\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let scene = shrad::scene::load(&dir.join("floor.obj"), &LoadOptions::default()).unwrap();
    let t = scene.objects[0].material.base_color_texture.as_ref();
    assert!(t.is_some(), "{:?}", scene.warnings);
    let uv = &scene.objects[0].mesh.uvs[0];
    assert!(uv[1].abs_diff_eq(Vec2::new(0.0, 1.0), 1e-6), "{uv:?}");
    // A bilinear 2 x 2 checker: on a 4 x 4 patch grid the first row's left half (under the
    // white texel) is brighter than its right half.
    let world = World::new(scene, PatchSizing::Size(0.25), Backend::Auto).unwrap();
    let r = row(&world);
    assert!(r[0] > r[2] + 0.1 && r[1] > r[3] + 0.1, "{r:?}");
    // The writers keep the factor only, and do not fail on a textured scene.
    shrad::scene::write_obj(&world.scene, &dir.join("out.obj")).unwrap();
    shrad::scene::write_gltf(&world.scene, &dir.join("out.gltf")).unwrap();
    let back = shrad::scene::load(&dir.join("out.gltf"), &LoadOptions::default()).unwrap();
    assert!(back.objects[0]
        .material
        .reflectance
        .abs_diff_eq(Vec3::splat(0.8), 1e-6));
}

#[test]
fn jpeg_in_a_data_uri_loads() {
    let dir = temp_dir("jpeg");
    // A flat grey JPEG (JPEG is lossy: a uniform image survives it).
    let img = image::RgbImage::from_pixel(16, 16, image::Rgb([128, 128, 128]));
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgb8(img)
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Jpeg,
        )
        .unwrap();
    let uri = format!("data:image/jpeg;base64,{}", base64::encode(&bytes));
    let path = floor_gltf(&dir, "floor", 1.0, None, |r| {
        textured(r, json!({}), json!({"index": 0}));
        r["images"] = json!([{ "uri": uri }]);
    });
    let scene = shrad::scene::load(&path, &LoadOptions::default()).unwrap();
    let t = scene.objects[0].material.base_color_texture.as_ref();
    assert!(t.is_some(), "{:?}", scene.warnings);
    let world = World::new(scene, PatchSizing::Size(0.5), Backend::Auto).unwrap();
    let want = 0.8 * srgb_to_linear(128.0 / 255.0);
    for p in world.patches.range(0) {
        assert!(
            (world.reflectance[p].x - want).abs() < 0.01,
            "{}",
            world.reflectance[p]
        );
    }
}

#[test]
fn normalized_byte_rgba_colours_multiply_the_factor() {
    let dir = temp_dir("colour-u8");
    // COLOR_0 as normalized UNSIGNED_BYTE VEC4 (alpha dropped), in a second buffer.
    let bytes: Vec<u8> = [[255u8, 51, 0, 7]; 4].concat();
    let path = floor_gltf(&dir, "floor", 1.0, None, |r| {
        r["buffers"].as_array_mut().unwrap().push(json!({
            "uri": format!("data:application/octet-stream;base64,{}", base64::encode(&bytes)),
            "byteLength": 16
        }));
        r["bufferViews"]
            .as_array_mut()
            .unwrap()
            .push(json!({"buffer": 1, "byteLength": 16}));
        r["accessors"].as_array_mut().unwrap().push(json!({
            "bufferView": 4, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC4"
        }));
        r["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(4);
    });
    let world = load_world(&path, 0.5);
    for p in world.patches.range(0) {
        assert!(
            world.reflectance[p].abs_diff_eq(Vec3::new(0.8, 0.16, 0.0), 1e-5),
            "{}",
            world.reflectance[p]
        );
    }
    // Not normalized: refused, naming the accessor.
    let path = floor_gltf(&dir, "bad", 1.0, None, |r| {
        r["accessors"][1]["componentType"] = json!(5121);
    });
    let e = shrad::scene::load(&path, &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("TEXCOORD_0"), "{e}");
}

#[test]
fn a_new_base_colour_multiplies_the_texture_as_one_loaded_with_it() {
    // The checker floor's factor set to another colour through the world equals, patch by
    // patch, the floor loaded with that factor in the file: the texture's footprint
    // averages times the new factor.
    let dir = temp_dir("recolour");
    checker_png(&dir.join("tex.png"), 4, 255, 64);
    let painted = [0.3, 0.6, 0.9];
    let file = |name: &str, factor: Option<[f32; 3]>| {
        floor_gltf(&dir, name, 1.0, None, |r| {
            textured(r, json!({"magFilter": NEAREST}), json!({"index": 0}));
            if let Some([a, b, c]) = factor {
                r["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] =
                    json!([a, b, c, 1.0]);
            }
        })
    };
    let mut world = load_world(&file("before", None), 0.2);
    let before = world.reflectance.clone();
    let factor = world.scene.objects[0].material.reflectance;
    assert!(world.set_reflectance(0, Vec3::from(painted)).unwrap());
    assert!(
        !world.set_reflectance(0, Vec3::from(painted)).unwrap(),
        "no change"
    );
    let loaded = load_world(&file("after", Some(painted)), 0.2);
    for p in world.patches.range(0) {
        let (got, want) = (world.reflectance[p], loaded.reflectance[p]);
        assert!(got.abs_diff_eq(want, 1e-4), "patch {p}: {got} vs {want}");
        let scaled = before[p] * Vec3::from(painted) / factor;
        assert!(
            got.abs_diff_eq(scaled, 1e-4),
            "patch {p}: {got} vs {scaled}"
        );
    }
    // The light quad (object 1) is not touched.
    let light = world.patches.range(1);
    assert_eq!(world.reflectance[light.clone()], before[light]);
}
