#!/usr/bin/env python3
"""A Blender material whose Base Color is keyed, exported by Blender's own glTF exporter with
"Animation Pointer" on (KHR_animation_pointer: `/materials/0/pbrMetallicRoughness/
baseColorFactor`), with what Blender has at some frames (JSON), to check that shrad's
reflectance follows Blender's keys.

The scene: a floor, a point lamp of 300 W; a cube "Paint" whose Principled BSDF's Base Color is keyed from a red
(0.8, 0.1, 0.1) at frame 1 to a blue (0.1, 0.2, 0.8) at frame 49 (24 frames/s; Blender's
default Bezier interpolation, so the exporter samples every frame; it puts frame f at
f / 24 s).

    /tmp/bpyenv/bin/python crates/shrad-scene/tests/data/blender/keyed_base_color.py OUT_DIR

writes OUT_DIR/keyed_base_color.glb and OUT_DIR/keyed_base_color.json: for frames 1, 13, 25,
37 and 49 the time in seconds and the cube's Base Color as Blender evaluates it there
(linear RGB, as glTF's baseColorFactor).
"""
import json
import os
import sys

import bpy

FRAMES = [1, 13, 25, 37, 49]


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = 1, 49
    bpy.ops.mesh.primitive_plane_add(size=6)
    bpy.context.object.name = "Floor"
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0, 0, 0.25))
    cube = bpy.context.object
    cube.name = "Paint"
    m = bpy.data.materials.new("paint")
    m.use_nodes = True
    base = m.node_tree.nodes["Principled BSDF"].inputs["Base Color"]
    for frame, rgb in [(1, (0.8, 0.1, 0.1)), (49, (0.1, 0.2, 0.8))]:
        base.default_value = (*rgb, 1.0)
        base.keyframe_insert("default_value", frame=frame)
    cube.data.materials.append(m)
    lamp = bpy.data.lights.new("lamp", "POINT")
    lamp.energy = 300.0
    lamp.shadow_soft_size = 0.0
    lamp_object = bpy.data.objects.new("lamp", lamp)
    lamp_object.location = (1.0, -1.0, 2.0)
    scene.collection.objects.link(lamp_object)
    return scene, base


def main():
    out_dir = sys.argv[-1]
    os.makedirs(out_dir, exist_ok=True)
    scene, base = build()
    bpy.ops.export_scene.gltf(
        filepath=os.path.join(out_dir, "keyed_base_color.glb"),
        export_format="GLB",
        export_lights=True,
        export_animations=True,
        export_pointer_animation=True,
        export_animation_mode="SCENE",
    )
    frames = []
    for f in FRAMES:
        scene.frame_set(f)
        frames.append({"frame": f, "time": f / 24.0,
                       "base_color": list(base.default_value)[:3]})
    with open(os.path.join(out_dir, "keyed_base_color.json"), "w") as out:
        json.dump({"frames": frames}, out, indent=1)


main()
