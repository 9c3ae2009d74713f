#!/usr/bin/env python3
"""A Cornell-like box whose floor has a checker texture, built in Blender, exported with
Blender's own glTF exporter, rendered with Cycles (CPU, Lambertian: Diffuse BSDF) and by
shrad's reference solver from the exported file; prints the block-averaged relative RMSE of
linear radiance (docs/validation.md's metric) over the whole picture and over the floor.

    /tmp/bpyenv/bin/python validation/blender_textures.py OUT_DIR [--spp 128] [--size 256]
        [--patches 8000] [--shrad ./target/release/shrad]

Writes OUT_DIR/textured_box.glb, checker.png, cycles.exr / .png, shrad_reference.exr / .png,
shrad_dispersive.exr / .png, and a JSON line of the numbers.
"""
import argparse, json, math, subprocess, sys, time
from pathlib import Path

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from blender_common import blocks, read_exr, rel_rmse, render_cycles, write_png  # noqa: E402

CHECKER = 8  # squares a side
LIGHT_SRGB, DARK_SRGB = 0.85, 0.25  # the squares' sRGB values (as stored in the PNG)


def srgb_to_linear(c):
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


# The checker's mean linear albedo (of the 8-bit values), for the untextured control.
MEAN = 0.5 * (srgb_to_linear(round(LIGHT_SRGB * 255) / 255) + srgb_to_linear(round(DARK_SRGB * 255) / 255))


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--spp", type=int, default=128)
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--patches", type=int, default=8000)
    p.add_argument("--block", type=int, default=8)
    p.add_argument("--shrad", default="./target/release/shrad")
    p.add_argument("--no-texture", action="store_true",
                   help="a plain floor of the checker's mean albedo instead (a control)")
    return p.parse_args(argv)


def principled(name, rgb, image=None, emit=None):
    """What the glTF exporter understands: Principled, roughness 1, no specular."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.use_backface_culling = True  # exported as single-sided, as shrad's walls are
    nt = m.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    if image is not None:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.image = image
        tex.interpolation = "Closest"
        nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    if emit is not None:
        bsdf.inputs["Emission Color"].default_value = (*emit[0], 1.0)
        bsdf.inputs["Emission Strength"].default_value = emit[1]
    return m


def lambertian(m, rgb, image=None, emit=None):
    """Replace the material's nodes for Cycles: a Diffuse BSDF (Lambert) taking the same
    colour or texture, plus front-side-only emission (shrad's lights emit on their front)."""
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diff = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diff.inputs["Roughness"].default_value = 0.0
    diff.inputs["Color"].default_value = (*rgb, 1.0)
    if image is not None:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.image = image
        tex.interpolation = "Closest"
        nt.links.new(tex.outputs["Color"], diff.inputs["Color"])
    shader = diff.outputs["BSDF"]
    if emit is not None:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = (*emit[0], 1.0)
        em.inputs["Strength"].default_value = emit[1]
        black = nt.nodes.new("ShaderNodeEmission")
        black.inputs["Strength"].default_value = 0.0
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        front = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geo.outputs["Backfacing"], front.inputs["Fac"])
        nt.links.new(em.outputs["Emission"], front.inputs[1])
        nt.links.new(black.outputs["Emission"], front.inputs[2])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(shader, add.inputs[0])
        nt.links.new(front.outputs["Shader"], add.inputs[1])
        shader = add.outputs["Shader"]
    nt.links.new(shader, out.inputs["Surface"])


def quad(name, corners, mat, uv=True):
    """A one-face mesh, counter-clockwise from its front, UVs (0,0) (1,0) (1,1) (0,1)."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(c) for c in corners], [], [(0, 1, 2, 3)])
    if uv:
        layer = me.uv_layers.new(name="UVMap")
        for k, (u, v) in enumerate([(0, 0), (1, 0), (1, 1), (0, 1)]):
            layer.data[k].uv = (u, v)
    me.materials.append(mat)
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def checker_image(path: Path):
    img = bpy.data.images.new("checker", CHECKER, CHECKER, alpha=False)
    px = np.zeros((CHECKER, CHECKER, 4), np.float32)
    for y in range(CHECKER):
        for x in range(CHECKER):
            px[y, x, :3] = LIGHT_SRGB if (x + y) % 2 == 0 else DARK_SRGB
    px[..., 3] = 1.0
    img.pixels[:] = px.ravel()
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    img.colorspace_settings.name = "sRGB"
    return img


def build(out: Path, textured: bool = True):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    img = checker_image(out / "checker.png")
    white, red, green = (0.73, 0.71, 0.68), (0.63, 0.065, 0.05), (0.14, 0.45, 0.091)
    mats = {
        "floor": (principled("floor", (1.0, 1.0, 1.0), image=img), (1.0, 1.0, 1.0), img, None)
        if textured else (principled("floor", (MEAN,) * 3), (MEAN,) * 3, None, None),
        "white": (principled("white", white), white, None, None),
        "red": (principled("red", red), red, None, None),
        "green": (principled("green", green), green, None, None),
        "light": (principled("light", (0.0, 0.0, 0.0), emit=((1.0, 0.85, 0.6), 15.0)),
                  (0.0, 0.0, 0.0), None, ((1.0, 0.85, 0.6), 15.0)),
    }
    m = {k: v[0] for k, v in mats.items()}
    # A 2 m box, Blender Z up, open towards -Y where the camera stands; faces point inward.
    quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], m["floor"])
    quad("ceiling", [(-1, -1, 2), (-1, 1, 2), (1, 1, 2), (1, -1, 2)], m["white"], uv=False)
    quad("back", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], m["white"], uv=False)
    quad("left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], m["red"], uv=False)
    quad("right", [(1, -1, 0), (1, -1, 2), (1, 1, 2), (1, 1, 0)], m["green"], uv=False)
    quad("light", [(-0.25, -0.25, 1.99), (-0.25, 0.25, 1.99), (0.25, 0.25, 1.99),
                   (0.25, -0.25, 1.99)], m["light"], uv=False)
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(50.0)
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = (0.0, -3.2, 1.0)
    cam.rotation_euler = (math.radians(90.0), 0.0, 0.0)
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    bpy.context.view_layer.update()
    glb = out / "textured_box.glb"
    bpy.ops.export_scene.gltf(filepath=str(glb), export_format="GLB", export_yup=True,
                              export_cameras=True, export_apply=False)
    for k, (mat, rgb, image, emit) in mats.items():
        lambertian(mat, rgb, image, emit)
    return glb







def main():
    a = args()
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    glb = build(out, not a.no_texture)
    t_cycles = render_cycles(out, a.size, a.spp)
    times = {}
    for solver in ["reference", "dispersive"]:
        cmd = [a.shrad, "render", str(glb), "--solver", solver, "--patches", str(a.patches),
               "--width", str(a.size), "--height", str(a.size), "--spp", "16",
               "-o", str(out / f"shrad_{solver}.png"), "--hdr", str(out / f"shrad_{solver}.exr"),
               "--quiet"]
        t0 = time.time()
        subprocess.run(cmd, check=True)
        times[solver] = time.time() - t0
    ref = read_exr(out / "cycles.exr")
    # One exposure for every picture: the Cycles image's 99th percentile of luminance -> 0.9.
    lum = ref @ np.array([0.2126, 0.7152, 0.0722])
    exposure = 0.9 / max(float(np.percentile(lum, 99)), 1e-9)
    write_png(out / "cycles.png", ref, exposure)
    for solver in ["reference", "dispersive"]:
        write_png(out / f"shrad_{solver}_same_exposure.png", read_exr(out / f"shrad_{solver}.exr"),
                  exposure)
    b = a.block
    rb = blocks(ref, b)
    # The floor's blocks: the lower part of the picture, below the back wall's bottom edge
    # (the camera looks level at z = 1 from 3.2 m: the floor's far edge is at row ~0.68 h).
    rows = np.arange(rb.shape[0]) * b + b / 2
    floor = np.zeros(rb.shape[:2], bool)
    floor[rows > 0.72 * ref.shape[0], :] = True
    floor[:, : int(0.2 * rb.shape[1])] = False
    floor[:, -int(0.2 * rb.shape[1]):] = False
    result = {"cycles_spp": a.spp, "size": a.size, "patches": a.patches, "block": b,
              "cycles_s": round(t_cycles, 1)}
    for solver in ["reference", "dispersive"]:
        sb = blocks(read_exr(out / f"shrad_{solver}.exr"), b)
        result[solver] = {
            "rel_rmse_all": round(rel_rmse(sb, rb), 4),
            "rel_rmse_floor": round(rel_rmse(sb, rb, floor), 4),
            "mean_ratio_rgb": [round(float(sb[..., k].mean() / rb[..., k].mean()), 4) for k in range(3)],
            "seconds": round(times[solver], 1),
        }
    # Checker contrast on the floor: the ratio of light to dark squares' radiance, per image.
    print(json.dumps(result))


main()
