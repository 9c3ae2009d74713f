#!/usr/bin/env python3
"""Linked duplicates under an empty, exported by Blender's own glTF exporter with "GPU
Instances" (EXT_mesh_gpu_instancing: one node draws the shared mesh once per child), with
where Blender has each duplicate's vertices (JSON), to check shrad's instancing against
Blender.

The scene: a floor, an emissive panel, and an empty "Forest" (turned 30 degrees about z,
scaled 1.5) holding four linked duplicates of one red cube: moved, turned about z and x,
stretched, scaled 2, and one mirrored (scale x -1).

    /tmp/bpyenv/bin/python crates/shrad-scene/tests/data/blender/gpu_instances.py OUT_DIR

writes OUT_DIR/gpu_instances.glb and OUT_DIR/gpu_instances.json: for each duplicate, its
name and the world positions of its mesh's vertices in glTF's +Y-up axes, C * matrix_world
* v (C: (x, y, z) -> (x, z, -y)).
"""
import json
import math
import os
import sys

import bpy

C = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]

# (location, rotation in degrees, scale) of each duplicate, in the empty's frame.
PLACES = [
    ((-4.0, 0.0, 0.5), (0, 0, 0), (1, 1, 1)),
    ((-1.0, 2.0, 0.5), (0, 0, 45), (1, 1, 2)),
    ((2.0, -2.0, 0.5), (0, 0, 10), (-1, 1, 1)),
    ((3.0, 3.0, 1.0), (30, 0, 0), (2, 2, 2)),
]


def material(name, colour, emission=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = colour
    if emission > 0.0:
        bsdf.inputs["Emission Color"].default_value = (1, 1, 1, 1)
        bsdf.inputs["Emission Strength"].default_value = emission
    return m


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, 0))
    bpy.context.object.name = "Floor"
    bpy.ops.mesh.primitive_plane_add(size=4, location=(0, 0, 8), rotation=(math.pi, 0, 0))
    lamp = bpy.context.object
    lamp.name = "Lamp"
    lamp.data.materials.append(material("Emit", (0.8, 0.8, 0.8, 1), emission=10.0))
    bpy.ops.object.empty_add(location=(0, 0, 0))
    forest = bpy.context.object
    forest.name = "Forest"
    forest.rotation_euler = (0, 0, math.radians(30))
    forest.scale = (1.5, 1.5, 1.5)
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, 0.5))
    first = bpy.context.object
    first.data.materials.append(material("Red", (0.8, 0.1, 0.1, 1)))
    crates = []
    for i, (loc, rot, scale) in enumerate(PLACES):
        o = first if i == 0 else first.copy()  # a copy shares the mesh: a linked duplicate
        if i > 0:
            scene.collection.objects.link(o)
        o.name = f"Crate{i}"
        o.parent = forest
        o.location = loc
        o.rotation_euler = tuple(math.radians(a) for a in rot)
        o.scale = scale
        crates.append(o)
    bpy.context.view_layer.update()
    return crates


def y_up(v):
    return [sum(C[i][k] * v[k] for k in range(3)) for i in range(3)]


def main():
    out = [a for a in sys.argv[1:] if not a.startswith("--")][-1]
    os.makedirs(out, exist_ok=True)
    crates = build()
    record = [
        {"name": o.name, "vertices": [y_up(list(o.matrix_world @ v.co)) for v in o.data.vertices]}
        for o in crates
    ]
    bpy.ops.export_scene.gltf(
        filepath=os.path.join(out, "gpu_instances.glb"),
        export_format="GLB",
        export_yup=True,
        export_gpu_instances=True,
        export_lights=False,
        export_cameras=False,
    )
    with open(os.path.join(out, "gpu_instances.json"), "w") as f:
        json.dump({"crates": record}, f, indent=1)


main()
