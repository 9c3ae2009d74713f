#!/usr/bin/env python3
"""Build a room in Blender the way users do (objects with unapplied scale, rotations, one
mirrored by a negative scale, an emissive ceiling panel) and export it with Blender's own
glTF exporter. Prints each object's world surface area as Blender measures it (JSON on the
last line), so shrad's patch areas can be checked against it.

    python validation/blender_export.py OUT.glb      # needs `pip install bpy` (CPython 3.11)
"""
import json, math, sys

import bpy  # noqa: E402  (bpy first: it makes bmesh importable)
import bmesh  # noqa: E402


def world_area(obj):
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.transform(obj.matrix_world)
    a = sum(f.calc_area() for f in bm.faces)
    bm.free()
    return a


def material(name, rgb, emit=None):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    if emit is not None:
        bsdf.inputs["Emission Color"].default_value = (*emit[0], 1.0)
        bsdf.inputs["Emission Strength"].default_value = emit[1]
    return m


def main():
    out = sys.argv[-1]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    # The room: a default cube scaled (not applied) to 4 x 3 x 5 m, normals turned inward.
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0, 0, 1.5))
    room = bpy.context.active_object
    room.name = "room"
    room.scale = (2.0, 2.5, 1.5)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode="OBJECT")
    room.data.materials.append(material("walls", (0.7, 0.68, 0.65)))
    # A ceiling panel light: a 2 m plane scaled to 1 x 0.6 m, facing down.
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0, 0, 2.99))
    light = bpy.context.active_object
    light.name = "light"
    light.scale = (0.5, 0.3, 1.0)
    light.rotation_euler = (math.pi, 0, 0)
    light.data.materials.append(material("panel", (0.0, 0.0, 0.0), emit=((1.0, 0.9, 0.8), 20.0)))
    # A red box: a 2 m cube scaled by 0.3 and turned.
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(-0.8, 0.6, 0.3))
    box = bpy.context.active_object
    box.name = "red_box"
    box.scale = (0.3, 0.3, 0.3)
    box.rotation_euler = (0, 0, math.radians(25))
    box.data.materials.append(material("red", (0.8, 0.1, 0.08)))
    # A blue slab: a 2 m cube scaled by (1, 0.5, 2) x 0.25, turned.
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.7, -0.5, 0.5))
    slab = bpy.context.active_object
    slab.name = "blue_slab"
    slab.scale = (0.25, 0.125, 0.5)
    slab.rotation_euler = (0, 0, math.radians(-20))
    slab.data.materials.append(material("blue", (0.1, 0.2, 0.8)))
    # A mirrored green column: negative x scale, as a user gets from "mirror" on an object.
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.9, 1.2, 0.6))
    col = bpy.context.active_object
    col.name = "green_mirrored"
    col.scale = (0.2 if "--no-mirror" in sys.argv else -0.2, 0.2, 0.6)
    col.rotation_euler = (0, 0, math.radians(10))
    col.data.materials.append(material("green", (0.1, 0.6, 0.15)))
    bpy.context.view_layer.update()
    areas = {o.name: world_area(o) for o in bpy.data.objects if o.type == "MESH"}
    bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_apply=False, export_yup=True)
    print(json.dumps(areas))


main()
