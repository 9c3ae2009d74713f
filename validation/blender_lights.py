#!/usr/bin/env python3
"""Blender lamps against Cycles: a point lamp, a sun and a spot, exported with Blender's own
glTF exporter (Punctual Lights on, "Standard" lighting mode) and rendered by shrad from the
exported GLB, against Blender's own Cycles render of the same scene (issue 21, item 5).

The scene (Blender, Z up, metres): an open corner of a room (a 5.5 x 5 floor, a back wall and
a left wall 2.5 high) with two boxes on the floor, all Lambertian, no light surface. It is
lit in turn by each lamp alone ("point", "sun"; the spot with three blends: "spot_sharp"
0.001, "spot" 0.05, "spot_default" 0.15) and by all three ("all"). For each
case the script builds the scene, exports it, renders Cycles (CPU, box filter, no
denoising, no clamping, 64 bounces, Diffuse BSDF, black world, Standard view transform,
linear OpenEXR) and shrad (reference solver and dispersive default) from the GLB at the
GLB's camera, and compares the linear pictures: relative RMSE of 8 x 8 pixel block means
(RGB), and the mean radiance ratio shrad / Cycles per channel.

Lamps are set up so that the exporter's punctual light is what Cycles renders: the point
and spot lamps have radius (`shadow_soft_size`) 0 and the sun angle 0 (the exporter drops
both: a Blender default lamp of radius 0.1 m casts softer shadows in Cycles than its glTF
light can), no nodes, no temperature, exposure 0, object scale 1.

    python3.11 -m venv /tmp/bpyenv && /tmp/bpyenv/bin/pip install bpy==5.0.1
    /tmp/bpyenv/bin/python validation/blender_lights.py OUT_DIR [--spp 256] [--size 256]
        [--patches 8000] [--cases point,sun,spot,...] [--noise] [--shrad ./target/release/shrad]

Writes OUT_DIR/CASE/lights.glb, cycles.exr / .png, shrad_reference.exr / .png,
shrad_dispersive.exr / .png (PNGs at one exposure per case, Cycles' 99th percentile) and
prints one JSON line per case: the block RMSE and mean ratios, for a spot the flux ratio its
two cone profiles predict (see spot_flux_ratio), with --noise Cycles' own noise (a second
render with another seed). Results: docs/validation.md, "Lights from Blender against Cycles".
"""
import argparse, json, math, subprocess, sys, time
from pathlib import Path

import bpy  # noqa: E402  (bpy first: it makes bmesh and mathutils importable)
import bmesh  # noqa: E402
import numpy as np  # noqa: E402

from blender_common import blocks, read_exr, rel_rmse, render_cycles, write_png  # noqa: E402
from mathutils import Euler, Vector  # noqa: E402

# case: (lamps, the spot's blend). "spot" has a thin blend, so the two renderers' cone edge
# profiles (below) differ only in a thin ring; "spot_sharp" a blend of 0.001 (no ring to
# speak of); "spot_default" Blender's default blend, 0.15.
CASES = {
    "point": (("point",), None),
    "sun": (("sun",), None),
    "spot": (("spot",), 0.05),
    "spot_sharp": (("spot",), 0.001),
    "spot_default": (("spot",), 0.15),
    "all": (("point", "sun", "spot"), 0.05),
}

# The lamps (Blender units: W for point and spot, W/m^2 for the sun).
POINT = dict(location=(0.9, -0.6, 2.0), energy=150.0, color=(1.0, 0.9, 0.8))
SUN = dict(direction=(-0.45, 0.55, -0.75), energy=3.0, color=(1.0, 0.95, 0.85))
SPOT = dict(location=(-0.6, -1.6, 2.4), target=(-1.0, 0.9, 0.0), energy=300.0,
            color=(0.85, 0.9, 1.0), size_deg=60.0)


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--patches", type=int, default=8000)
    p.add_argument("--shrad-spp", type=int, default=16)
    p.add_argument("--block", type=int, default=8)
    p.add_argument("--cases", default="point,sun,spot,spot_sharp,spot_default,all")
    p.add_argument("--noise", action="store_true",
                   help="render Cycles twice (seeds 0 and 1): its own noise, RMSE(c0, c1) / sqrt 2")
    p.add_argument("--shrad", default="./target/release/shrad")
    return p.parse_args(argv)


def principled(name, rgb):
    """What the glTF exporter understands: Principled, roughness 1, no specular."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.use_backface_culling = True  # exported as single-sided, as shrad's walls are
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return m


def lambertian(m, rgb):
    """After the export, for Cycles: a plain Diffuse BSDF (Lambert) of the same colour."""
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    diff = nt.nodes.new("ShaderNodeBsdfDiffuse")
    diff.inputs["Roughness"].default_value = 0.0
    diff.inputs["Color"].default_value = (*rgb, 1.0)
    nt.links.new(diff.outputs["BSDF"], out.inputs["Surface"])


def link(name, me):
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def quad(name, corners, mat):
    """A one-face mesh, counter-clockwise seen from its front."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(c) for c in corners], [], [(0, 1, 2, 3)])
    me.materials.append(mat)
    return link(name, me)


def box(name, size, location, yaw_deg, mat):
    """A closed box, faces outward, standing on z = 0 at `location` (x, y), turned about Z."""
    me = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bmesh.ops.scale(bm, vec=Vector(size), verts=bm.verts)
    bm.to_mesh(me)
    bm.free()
    me.materials.append(mat)
    ob = link(name, me)
    ob.location = (location[0], location[1], size[2] / 2)
    ob.rotation_euler = Euler((0.0, 0.0, math.radians(yaw_deg)))
    return ob


def aim(ob, direction):
    """Point the object's local -Z along `direction` (lamps and cameras look along -Z)."""
    ob.rotation_euler = Vector(direction).normalized().to_track_quat("-Z", "Y").to_euler()


def lamp(kind, name):
    data = bpy.data.lights.new(name, kind)
    ob = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(ob)
    data.use_nodes = False
    data.exposure = 0.0
    if hasattr(data, "use_temperature"):
        data.use_temperature = False
    return data, ob


def build(out: Path, case: str):
    lamps, blend = CASES[case]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    rgb = {
        "floor": (0.7, 0.7, 0.7),
        "back": (0.6, 0.5, 0.4),
        "left": (0.65, 0.25, 0.2),
        "box": (0.25, 0.45, 0.7),
        "tower": (0.7, 0.65, 0.3),
    }
    mats = {k: principled(k, v) for k, v in rgb.items()}
    x0, x1, y0, y1, h = -2.5, 3.0, -3.0, 2.0, 2.5
    # The floor ends at the walls, so no surface sees a wall's back (Cycles' surfaces are
    # two-sided, shrad's are not).
    quad("floor", [(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)], mats["floor"])
    quad("back", [(x0, y1, 0), (x1, y1, 0), (x1, y1, h), (x0, y1, h)], mats["back"])
    quad("left", [(x0, y0, 0), (x0, y1, 0), (x0, y1, h), (x0, y0, h)], mats["left"])
    box("box", (0.8, 0.8, 0.8), (0.5, 0.1), 25.0, mats["box"])
    box("tower", (0.5, 0.5, 1.3), (-1.3, 0.9), -15.0, mats["tower"])
    if "point" in lamps:
        d, ob = lamp("POINT", "point")
        d.energy = POINT["energy"]
        d.color = POINT["color"]
        d.shadow_soft_size = 0.0
        ob.location = POINT["location"]
    if "sun" in lamps:
        d, ob = lamp("SUN", "sun")
        d.energy = SUN["energy"]
        d.color = SUN["color"]
        d.angle = 0.0
        ob.location = (0.0, 0.0, 5.0)  # a sun's position does not matter
        aim(ob, SUN["direction"])
    if "spot" in lamps:
        d, ob = lamp("SPOT", "spot")
        d.energy = SPOT["energy"]
        d.color = SPOT["color"]
        d.shadow_soft_size = 0.0
        d.spot_size = math.radians(SPOT["size_deg"])
        d.spot_blend = blend
        ob.location = SPOT["location"]
        aim(ob, Vector(SPOT["target"]) - Vector(SPOT["location"]))
    cam_data = bpy.data.cameras.new("camera")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(55.0)
    cam = bpy.data.objects.new("camera", cam_data)
    cam.location = (1.8, -5.6, 3.7)
    aim(cam, Vector((-0.2, 0.2, 0.5)) - Vector(cam.location))
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.scene.camera = cam
    bpy.context.view_layer.update()
    glb = out / "lights.glb"
    bpy.ops.export_scene.gltf(filepath=str(glb), export_format="GLB", export_yup=True,
                              export_cameras=True, export_lights=True,
                              export_import_convert_lighting_mode="SPEC", export_apply=False)
    for k, m in mats.items():
        lambertian(m, rgb[k])
    return glb





def spot_flux_ratio(size_deg: float, blend: float) -> float:
    """The spot's flux in shrad over Cycles' (both of the same intensity on the axis), from
    the two cone profiles: shrad (glTF's recommendation) t^2 with t linear in cos a between
    the exported cones, outer = size / 2 and inner = outer (1 - blend); Cycles a smoothstep
    in cos a from cos(outer) over (1 - cos outer) blend. Both integrated over d(cos a)."""
    co = math.cos(math.radians(size_deg / 2))
    ci = math.cos(math.radians(size_deg / 2 * (1 - blend)))
    shrad = (1 - ci) + (ci - co) / 3
    cycles = (1 - co) - (1 - co) * blend / 2
    return shrad / cycles




def run_case(a, case: str) -> dict:
    out = Path(a.out).resolve() / case
    out.mkdir(parents=True, exist_ok=True)
    glb = build(out, case)
    t_cycles = render_cycles(out, a.size, a.spp)
    times = {}
    for solver in ["reference", "dispersive"]:
        cmd = [a.shrad, "render", str(glb), "--solver", solver, "--patches", str(a.patches),
               "--width", str(a.size), "--height", str(a.size), "--spp", str(a.shrad_spp),
               "-o", str(out / f"shrad_{solver}_auto.png"),
               "--hdr", str(out / f"shrad_{solver}.exr"), "--quiet"]
        t0 = time.time()
        subprocess.run(cmd, check=True)
        times[solver] = time.time() - t0
    ref = read_exr(out / "cycles.exr")
    lum = ref @ np.array([0.2126, 0.7152, 0.0722])
    exposure = 0.9 / max(float(np.percentile(lum, 99)), 1e-9)
    write_png(out / "cycles.png", ref, exposure)
    rb = blocks(ref, a.block)
    result = {"case": case, "cycles_spp": a.spp, "size": a.size, "patches": a.patches,
              "shrad_spp": a.shrad_spp, "block": a.block, "cycles_s": round(t_cycles, 1),
              "cycles_mean_rgb": [round(float(ref[..., k].mean()), 5) for k in range(3)]}
    blend = CASES[case][1]
    if CASES[case][0] == ("spot",):
        result["spot_flux_ratio_predicted"] = round(spot_flux_ratio(SPOT["size_deg"], blend), 4)
    if a.noise:
        result["cycles_seed1_s"] = round(render_cycles(out, a.size, a.spp, 1, "cycles_seed1"), 1)
        other = blocks(read_exr(out / "cycles_seed1.exr"), a.block)
        result["cycles_noise"] = round(rel_rmse(other, rb) / math.sqrt(2.0), 4)
    for solver in ["reference", "dispersive"]:
        img = read_exr(out / f"shrad_{solver}.exr")
        write_png(out / f"shrad_{solver}.png", img, exposure)
        sb = blocks(img, a.block)
        result[solver] = {
            "rel_rmse": round(rel_rmse(sb, rb), 4),
            "mean_ratio_rgb": [round(float(sb[..., k].mean() / rb[..., k].mean()), 4)
                               for k in range(3)],
            "seconds": round(times[solver], 1),
        }
    return result


def main():
    a = args()
    for case in a.cases.split(","):
        if case not in CASES:
            sys.exit(f"unknown case {case!r}: one of {', '.join(CASES)}")
    for case in a.cases.split(","):
        print(json.dumps(run_case(a, case)), flush=True)


main()
