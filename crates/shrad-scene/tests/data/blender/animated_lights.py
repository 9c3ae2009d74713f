#!/usr/bin/env python3
"""Blender lamps and an emissive material whose values are keyed, exported by Blender's own
glTF exporter with "Animation Pointer" on (KHR_animation_pointer: a lamp's power, colour
and spot size and a material's emission strength), with what Blender has at some frames
(JSON), to check that shrad's lights and emission follow Blender's keys.

The scene: a floor; a cube whose material's Emission Strength is keyed 1 -> 5; a point lamp
whose power is keyed 100 -> 400 W and colour white -> red, and which moves; a spot whose
power is 300 W and whose spot size is keyed 40 -> 90 degrees and blend 0.1 -> 0.3; a
camera whose focal length is keyed 35 -> 20 mm (its field of view, the camera's `yfov` in
glTF). Keys at frames 1 and 49 (24 frames/s; the exporter puts frame f at f / 24 s),
Blender's default Bezier interpolation, so the exporter samples every frame.

    /tmp/bpyenv/bin/python crates/shrad-scene/tests/data/blender/animated_lights.py OUT_DIR

writes OUT_DIR/animated_lights.glb and OUT_DIR/animated_lights.json: for frames 1, 13, 25,
37 and 49 the time in seconds and, as Blender evaluates them there, each lamp's power (W),
colour, spot size and blend, the cube's emission colour and strength, and the camera's
`yfov` as Blender's exporter writes the still camera at that frame.
"""
import json
import math
import os
import sys
import tempfile

import bpy

FRAMES = [1, 13, 25, 37, 49]


def keyed(owner, prop, frames_values):
    for frame, value in frames_values:
        setattr(owner, prop, value)
        owner.keyframe_insert(prop, frame=frame)


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = 1, 49
    bpy.ops.mesh.primitive_plane_add(size=6)
    bpy.context.object.name = "Floor"
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0, 0, 0.25))
    cube = bpy.context.object
    cube.name = "Glow"
    m = bpy.data.materials.new("glow")
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    strength = bsdf.inputs["Emission Strength"]
    keyed(strength, "default_value", [(1, 1.0), (49, 5.0)])
    cube.data.materials.append(m)

    point = bpy.data.lights.new("bulb", "POINT")
    point.shadow_soft_size = 0.0
    keyed(point, "energy", [(1, 100.0), (49, 400.0)])
    keyed(point, "color", [(1, (1.0, 1.0, 1.0)), (49, (1.0, 0.2, 0.2))])
    bulb = bpy.data.objects.new("bulb", point)
    scene.collection.objects.link(bulb)
    keyed(bulb, "location", [(1, (1.0, 1.0, 2.0)), (49, (-1.0, 1.0, 2.0))])

    spot = bpy.data.lights.new("spot", "SPOT")
    spot.shadow_soft_size = 0.0
    spot.energy = 300.0
    keyed(spot, "spot_size", [(1, math.radians(40.0)), (49, math.radians(90.0))])
    keyed(spot, "spot_blend", [(1, 0.1), (49, 0.3)])
    lamp = bpy.data.objects.new("spot", spot)
    scene.collection.objects.link(lamp)
    lamp.location = (0.0, -1.5, 2.5)

    cam = bpy.data.cameras.new("view")
    keyed(cam, "lens", [(1, 35.0), (49, 20.0)])
    view = bpy.data.objects.new("view", cam)
    scene.collection.objects.link(view)
    view.location = (0.0, -6.0, 4.0)
    view.rotation_euler = (math.radians(58.0), 0.0, 0.0)
    scene.camera = view
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    return scene, strength, bsdf


def still_yfov(frame):
    """The camera's yfov as Blender's exporter writes it still at `frame`."""
    bpy.context.scene.frame_set(frame)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "still.gltf")
        bpy.ops.export_scene.gltf(filepath=path, export_format="GLTF_SEPARATE",
                                  export_cameras=True, export_animations=False,
                                  export_current_frame=True)
        with open(path) as f:
            return json.load(f)["cameras"][0]["perspective"]["yfov"]


def record(scene, strength, bsdf):
    out = {"frames": []}
    for f in FRAMES:
        scene.frame_set(f)
        lamps = {}
        for name in ("bulb", "spot"):
            light = bpy.data.lights[name]
            lamps[name] = {
                "energy": light.energy,
                "color": list(light.color),
                "spot_size": getattr(light, "spot_size", None),
                "spot_blend": getattr(light, "spot_blend", None),
            }
        out["frames"].append({
            "frame": f,
            "time": f / scene.render.fps,
            "lamps": lamps,
            "emission_color": list(bsdf.inputs["Emission Color"].default_value)[:3],
            "emission_strength": strength.default_value,
            "camera_yfov": still_yfov(f),
        })
    return out


def main():
    out_dir = sys.argv[-1]
    os.makedirs(out_dir, exist_ok=True)
    scene, strength, bsdf = build()
    glb = os.path.join(out_dir, "animated_lights.glb")
    bpy.ops.export_scene.gltf(
        filepath=glb,
        export_format="GLB",
        export_lights=True,
        export_cameras=True,
        export_animations=True,
        export_pointer_animation=True,
        export_animation_mode="SCENE",
    )
    with open(os.path.join(out_dir, "animated_lights.json"), "w") as f:
        json.dump(record(scene, strength, bsdf), f, indent=1)


main()
