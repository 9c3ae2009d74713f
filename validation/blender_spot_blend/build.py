#!/usr/bin/env python3
"""Build the spot-in-a-box scene in bpy, export it with Blender's glTF exporter and render
it with Cycles.

    bpy-venv/bin/python build.py OUTDIR --size 90 --blend 0.3 [--walls 0.6] [--floor 0.6]
        [--spp 512] [--bounces 32] [--seed 0] [--no-render] [--res 320x240]

Room (Blender, Z up, metres): floor x,y in [-4,4], z in [0,3], closed, normals inward.
Spot at (0,0,2.95) pointing straight down (-Z), 1000 W, radius 0, soft falloff off.
Camera at (0,-3.6,2.7) looking at (0,0.5,0), 90 deg horizontal fov, 4:3.
The exported materials are Principled (base colour = albedo, roughness 1, metallic 0,
specular IOR level 0); for the Cycles render they are swapped for a Diffuse BSDF (Lambert,
roughness 0) of the same albedo (what shrad models).
"""
import argparse, json, math, sys, time
from pathlib import Path

import bpy
import bmesh
from mathutils import Vector

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from blender_common import black_world  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--size", type=float, default=90.0)
ap.add_argument("--blend", type=float, default=0.3)
ap.add_argument("--walls", type=float, default=0.6, help="albedo of walls+ceiling")
ap.add_argument("--floor", type=float, default=0.6)
ap.add_argument("--power", type=float, default=1000.0)
ap.add_argument("--spp", type=int, default=512)
ap.add_argument("--bounces", type=int, default=32)
ap.add_argument("--seed", type=int, default=0)
ap.add_argument("--res", default="320x240")
ap.add_argument("--no-render", action="store_true")
ap.add_argument("--no-export", action="store_true")
ap.add_argument("--name", default="cycles")
a = ap.parse_args()
out = Path(a.out)
out.mkdir(parents=True, exist_ok=True)
W, H = map(int, a.res.split("x"))

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene

HX, HY, HZ = 4.0, 4.0, 3.0


def principled(name, alb):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    m.use_backface_culling = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (alb, alb, alb, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Metallic"].default_value = 0.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return m


def to_diffuse(m):
    nt = m.node_tree
    p = nt.nodes["Principled BSDF"]
    col = tuple(p.inputs["Base Color"].default_value)
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = col
    d.inputs["Roughness"].default_value = 0.0
    outn = nt.nodes["Material Output"]
    nt.links.new(d.outputs["BSDF"], outn.inputs["Surface"])


def mesh_obj(name, quads, mat):
    me = bpy.data.meshes.new(name)
    verts, faces = [], []
    for q in quads:
        base = len(verts)
        verts += q
        faces.append(tuple(range(base, base + 4)))
    me.from_pydata(verts, [], faces)
    me.update()
    me.materials.append(mat)
    ob = bpy.data.objects.new(name, me)
    sc.collection.objects.link(ob)
    return ob


# Quads wound so the normal points into the room.
x0, x1, y0, y1, z0, z1 = -HX, HX, -HY, HY, 0.0, HZ
floor = [[(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)]]            # +Z
rest = [
    [(x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1)],                  # ceiling -Z
    [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],                  # x0 wall +X
    [(x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)],                  # x1 wall -X
    [(x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0)],                  # y0 wall +Y
    [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],                  # y1 wall -Y
]
mf = principled("floor", a.floor)
mw = principled("walls", a.walls)
fo = mesh_obj("Floor", floor, mf)
ro = mesh_obj("Walls", rest, mw)
# check normals
for ob in (fo, ro):
    for p in ob.data.polygons:
        c = p.center
        assert p.normal.dot(Vector((0, 0, 1.5)) - c) > 0, (ob.name, p.index, p.normal)

ld = bpy.data.lights.new("Spot", "SPOT")
ld.energy = a.power
ld.spot_size = math.radians(a.size)
ld.spot_blend = a.blend
ld.shadow_soft_size = 0.0
ld.use_soft_falloff = False
ld.color = (1.0, 1.0, 1.0)
ld.exposure = 0.0
lo = bpy.data.objects.new("Spot", ld)
lo.location = (0.0, 0.0, 2.95)
lo.rotation_euler = (0.0, 0.0, 0.0)   # local -Z = world -Z: straight down
sc.collection.objects.link(lo)

cd = bpy.data.cameras.new("Cam")
cd.type = "PERSP"
cd.sensor_fit = "HORIZONTAL"
cd.angle = math.radians(90.0)
cd.clip_start = 0.05
cd.clip_end = 100.0
co = bpy.data.objects.new("Cam", cd)
co.location = (0.0, -3.6, 2.7)
d = Vector((0.0, 0.5, 0.0)) - co.location
co.rotation_euler = d.to_track_quat("-Z", "Y").to_euler()
sc.collection.objects.link(co)
sc.camera = co
sc.render.resolution_x, sc.render.resolution_y = W, H
sc.render.resolution_percentage = 100
sc.render.pixel_aspect_x = sc.render.pixel_aspect_y = 1.0

black_world(sc)

bpy.context.view_layer.update()
info = dict(size=a.size, blend=a.blend, walls=a.walls, floor=a.floor, power=a.power,
            spot=list(lo.location), cam=list(co.location),
            cam_matrix=[list(r) for r in co.matrix_world], angle_x=cd.angle_x, angle_y=cd.angle_y,
            res=[W, H], blender=bpy.app.version_string)

if not a.no_export:
    bpy.ops.export_scene.gltf(filepath=str(out / "scene.glb"), export_format="GLB",
                              export_lights=True, export_cameras=True, export_yup=True,
                              export_import_convert_lighting_mode="SPEC", export_apply=True)

if not a.no_render:
    to_diffuse(mf)
    to_diffuse(mw)
    sc.render.engine = "CYCLES"
    c = sc.cycles
    c.device = "CPU"
    c.seed = a.seed
    c.samples = a.spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = a.bounces
    c.diffuse_bounces = a.bounces
    c.glossy_bounces = a.bounces
    c.transmission_bounces = 0
    c.volume_bounces = 0
    c.transparent_max_bounces = 8
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.min_light_bounces = 0
    c.light_sampling_threshold = 0.0
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    sc.render.use_compositing = False
    sc.render.use_sequencer = False
    sc.render.threads_mode = "FIXED"
    sc.render.threads = 2
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.image_settings.color_mode = "RGB"
    sc.render.image_settings.exr_codec = "ZIP"
    sc.render.filepath = str(out / f"{a.name}.exr")
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    info["cycles_seconds"] = time.time() - t0
    info["cycles"] = dict(samples=c.samples, max_bounces=c.max_bounces,
                          diffuse_bounces=c.diffuse_bounces, filter=c.pixel_filter_type,
                          filter_width=c.filter_width, seed=c.seed,
                          view=sc.view_settings.view_transform,
                          light_sampling_threshold=c.light_sampling_threshold)
(out / f"{a.name}.json").write_text(json.dumps(info, indent=1))
print("DONE", json.dumps({k: v for k, v in info.items() if k != "cam_matrix"}))
