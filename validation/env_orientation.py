#!/usr/bin/env python3
"""Which way does an equirectangular map face? shrad against Mitsuba 3 and Blender Cycles.

A 360 x 180 "coordinate" map (linear EXR) holds in each texel its own (u, v): red = u, green
= v (texel centres, u from the left edge, v from the top row), blue = 1. A camera at the
origin with a 1-degree field of view (3 x 3 pixels; 5 x 5 in Blender) looks along each of eight directions (glTF axes, +Y up:
the four horizontal axes and four between them, 20 degrees above the horizon) and reads the
(u, v) it sees. Mitsuba 3 (`envmap`) and shrad (`[environment] file`) are run by default;
run the same script under Blender's Python to get Cycles' World > Environment Texture
(equirectangular) on the same map, the direction converted to Blender's Z-up axes
((x, y, z) glTF = (x, z, -y) Blender).

    target/validation-venv/bin/python validation/env_orientation.py OUT_DIR [--shrad PATH]
    /tmp/bpyenv/bin/python validation/env_orientation.py OUT_DIR --blender

Prints one line per direction: the direction, the (u, v) each renderer saw, and the (u, v)
of shrad's documented convention, d = (sin 2 pi u sin pi v, cos pi v, -cos 2 pi u sin pi v).
"""
import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

W, H = 360, 180
ELEV = math.radians(20.0)
AZIMUTHS = {  # name: the horizontal direction (x, z), glTF axes
    "+X": (1, 0), "+X+Z": (1, 1), "+Z": (0, 1), "-X+Z": (-1, 1),
    "-X": (-1, 0), "-X-Z": (-1, -1), "-Z": (0, -1), "+X-Z": (1, -1),
}


def direction(name):
    x, z = AZIMUTHS[name]
    n = math.hypot(x, z)
    c = math.cos(ELEV)
    return (c * x / n, math.sin(ELEV), c * z / n)


def documented_uv(d):
    """(u, v) of d by docs/scene-format.md's formula, the inverse of
    d = (sin 2 pi u sin pi v, cos pi v, -cos 2 pi u sin pi v)."""
    u = math.atan2(d[0], -d[2]) / (2 * math.pi)
    return (u % 1.0, math.acos(d[1]) / math.pi)


def coordinate_map():
    u = (np.arange(W) + 0.5) / W
    v = (np.arange(H) + 0.5) / H
    img = np.ones((H, W, 3), np.float32)
    img[..., 0] = u[None, :]
    img[..., 1] = v[:, None]
    return img  # row 0 at the top


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--shrad", default="./target/release/shrad")
    p.add_argument("--blender", action="store_true")
    p.add_argument("--rotate", type=float, default=0.0,
                   help="turn the map about +Y by DEG: shrad's rotate_deg, Mitsuba's "
                        "to_world = rotate(+Y, DEG) (not applied to Blender)")
    return p.parse_args(argv)


def mitsuba_uv(env: Path, d, rotate: float):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    T = mi.ScalarTransform4f
    up = (0, 0, 1) if abs(d[1]) > 0.99 else (0, 1, 0)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 1.0,
                   "to_world": T().look_at(origin=(0, 0, 0), target=d, up=up),
                   "sampler": {"type": "independent", "sample_count": 4},
                   "film": {"type": "hdrfilm", "width": 3, "height": 3, "rfilter": {"type": "box"}}},
        "sky": {"type": "envmap", "filename": str(env),
                "to_world": T().rotate(axis=(0, 1, 0), angle=rotate)},
    })
    img = np.array(mi.render(scene))
    return tuple(float(c) for c in img[1, 1, :2])


def shrad_uv(shrad: str, env: Path, d, out: Path, rotate: float):
    import mitsuba as mi

    # A small quad far behind the camera, facing away, so the scene is not empty.
    b = [-100 * c for c in d]
    toml = out / "env_orientation.toml"
    toml.write_text(
        f"[camera]\neye = [0, 0, 0]\ntarget = {list(d)}\nyfov_deg = 1.0\n\n"
        f'[environment]\nfile = "{env.name}"\nrotate_deg = {rotate}\n\n'
        f'[[object]]\nname = "speck"\nshape = "box"\nsize = [0.1, 0.1, 0.1]\n'
        f"position = {b}\nreflectance = [0.5, 0.5, 0.5]\n")
    exr = out / "env_orientation_shrad.exr"
    subprocess.run([shrad, "render", str(toml), "--width", "3", "--height", "3", "--spp", "1",
                    "--patches", "200", "-o", str(out / "env_orientation_shrad.png"),
                    "--hdr", str(exr), "--quiet"], check=True)
    img = np.array(mi.Bitmap(str(exr)))
    return tuple(float(c) for c in img[1, 1, :2])


def blender_uv(env, d):
    import bpy
    from mathutils import Vector

    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = 4
    sc.cycles.use_denoising = False  # on by default: it smears a 5 x 5 picture
    sc.cycles.pixel_filter_type = "BOX"
    sc.view_settings.view_transform = "Standard"
    sc.render.resolution_x = sc.render.resolution_y = 5  # Blender's smallest is 4
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    world = bpy.data.worlds.new("env")
    world.use_nodes = True  # still needed in 5.0 for a world made in Python
    nt = world.node_tree
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = blender_map()
    tex.interpolation = "Closest"
    bg = nt.nodes["Background"]
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    sc.world = world
    cam_data = bpy.data.cameras.new("camera")
    cam_data.angle = math.radians(1.0)
    cam = bpy.data.objects.new("camera", cam_data)
    sc.collection.objects.link(cam)
    sc.camera = cam
    bd = Vector((d[0], -d[2], d[1]))  # glTF -> Blender axes
    cam.rotation_euler = bd.to_track_quat("-Z", "Y").to_euler()
    out = Path(bpy.app.tempdir) / "env_orientation_cycles.exr"
    sc.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(str(out))
    w, h = img.size
    px = np.array(img.pixels[:], np.float64).reshape(h, w, 4)
    return tuple(float(c) for c in px[h // 2, w // 2, :2])


def write_map_mitsuba(path: Path):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    mi.Bitmap(coordinate_map()).write(str(path))


def blender_map():
    """The map as a float image in memory (scene-linear; not saved: an EXR that Blender
    writes from a generated image comes back tagged sRGB)."""
    import bpy

    img = bpy.data.images.new("coords", W, H, alpha=False, float_buffer=True)
    px = np.ones((H, W, 4), np.float32)
    px[..., :3] = coordinate_map()[::-1]  # Blender's rows go bottom up
    img.pixels[:] = px.ravel()
    return img


def main():
    a = args()
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    env = out / "coords.exr"
    if not a.blender:
        write_map_mitsuba(env)
    who = ["cycles"] if a.blender else ["mitsuba", "shrad"]
    print("direction (glTF)       " + "".join(f"{w + ' (u, v)':>18}" for w in who)
          + "   documented (u, v)")
    for name in AZIMUTHS:
        d = direction(name)
        if a.blender:
            seen = [blender_uv(env, d)]
        else:
            seen = [mitsuba_uv(env, d, a.rotate), shrad_uv(a.shrad, env, d, out, a.rotate)]
        cells = "".join(f"{'(%.3f, %.3f)' % s:>18}" for s in seen)
        print(f"{name:5} {'(%.2f %.2f %.2f)' % d:17}" + cells
              + "   (%.3f, %.3f)" % documented_uv(d) * (a.rotate == 0), flush=True)


main()
