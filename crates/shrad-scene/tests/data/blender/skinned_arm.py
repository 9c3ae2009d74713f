#!/usr/bin/env python3
"""A skinned arm posed by an animated armature in Blender, exported by Blender's own glTF
exporter (a skin with two joints, their rotations keyed), with the arm's vertices as
Blender's armature deforms them at some frames (JSON), to check that shrad's rigid parts
of a skinned mesh follow Blender's skinning.

The scene: a floor (a plane); an upright box arm, 2 m tall, cut into 8 rings along its
height; an armature (its object mirrored: scaled by (-1.5, 1, 1), and turned 30 degrees
about z) of two bones, "upper" from z = 0 to 1 and "fore" from z = 1 to 2 (a
child of "upper"). Every vertex below z = 1 belongs to "upper" alone and every vertex above
to "fore" alone (the ring at z = 1 to "upper"), so the skinning is rigid and shrad's parts
must be exactly where Blender puts the vertices. Keys at frames 1 and 49 (24 frames/s: the
exporter puts frame f at f / 24 s): "upper" turns 30 degrees about x, "fore" 80 degrees
about x; Blender's default Bezier interpolation, so the exporter samples every frame. A
point lamp and a camera looking at the arm make the file one to render.

    /tmp/bpyenv/bin/python crates/shrad-scene/tests/data/blender/skinned_arm.py OUT_DIR

writes OUT_DIR/skinned_arm.glb and OUT_DIR/skinned_arm.json: for frames 1, 13, 25, 37 and
49 the time in seconds and every vertex of the arm in world space (glTF's axes: y up) as
Blender's armature modifier deforms it there.
"""
import json
import math
import os
import sys

import bpy
import bmesh  # after bpy, which makes it importable
from mathutils import Vector

FRAMES = [1, 13, 25, 37, 49]


def arm_mesh():
    """A 0.3 x 0.3 x 2 box along z from 0 to 2, eight rings of four vertices."""
    mesh = bpy.data.meshes.new("ArmMesh")
    bm = bmesh.new()
    rings = []
    for k in range(9):
        z = 2.0 * k / 8
        rings.append([bm.verts.new((x, y, z)) for x, y in
                      [(-0.15, -0.15), (0.15, -0.15), (0.15, 0.15), (-0.15, 0.15)]])
    for a, b in zip(rings, rings[1:]):
        for i in range(4):
            j = (i + 1) % 4
            bm.faces.new((a[i], a[j], b[j], b[i]))
    bm.faces.new(list(reversed(rings[0])))
    bm.faces.new(rings[-1])
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 24
    scene.frame_start, scene.frame_end = 1, 49
    bpy.ops.mesh.primitive_plane_add(size=6.0, location=(0.0, 0.0, 0.0))
    bpy.context.object.name = "Floor"

    arm_data = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", arm_data)
    scene.collection.objects.link(rig)
    # The rig mirrored, stretched and turned, as a scene may place one.
    rig.scale = (-1.5, 1.0, 1.0)
    rig.rotation_euler = (0.0, 0.0, math.radians(30.0))
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    upper = arm_data.edit_bones.new("upper")
    upper.head, upper.tail = (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    fore = arm_data.edit_bones.new("fore")
    fore.head, fore.tail = (0.0, 0.0, 1.0), (0.0, 0.0, 2.0)
    fore.parent = upper
    bpy.ops.object.mode_set(mode="OBJECT")

    arm = bpy.data.objects.new("Arm", arm_mesh())
    scene.collection.objects.link(arm)
    arm.parent = rig
    groups = {name: arm.vertex_groups.new(name=name) for name in ("upper", "fore")}
    for v in arm.data.vertices:
        name = "upper" if v.co.z <= 1.0 + 1e-6 else "fore"
        groups[name].add([v.index], 1.0, "REPLACE")
    modifier = arm.modifiers.new("Armature", "ARMATURE")
    modifier.object = rig

    for name, degrees in (("upper", 30.0), ("fore", 80.0)):
        bone = rig.pose.bones[name]
        bone.rotation_mode = "XYZ"
        for frame, angle in ((1, 0.0), (49, degrees)):
            bone.rotation_euler = (math.radians(angle), 0.0, 0.0)
            bone.keyframe_insert("rotation_euler", frame=frame)

    bpy.ops.object.light_add(type="POINT", location=(1.5, -1.5, 3.0))
    bpy.context.object.data.energy = 500.0
    bpy.ops.object.camera_add(location=(4.0, -4.0, 2.5))
    camera = bpy.context.object
    direction = Vector((0.0, 0.0, 1.0)) - camera.location
    camera.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    return scene, arm


def deformed(scene, arm):
    """The arm's vertices at each of FRAMES as Blender deforms them, in glTF's axes."""
    out = []
    for frame in FRAMES:
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        evaluated = arm.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        world = evaluated.matrix_world
        # Blender's z up is glTF's y up: (x, y, z) -> (x, z, -y).
        points = [world @ Vector(v.co) for v in mesh.vertices]
        out.append({
            "frame": frame,
            "time": frame / scene.render.fps,
            "vertices": [[p.x, p.z, -p.y] for p in points],
        })
        evaluated.to_mesh_clear()
    return out


def main():
    out_dir = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else sys.argv[1]
    os.makedirs(out_dir, exist_ok=True)
    scene, arm = build()
    frames = deformed(scene, arm)
    scene.frame_set(1)
    glb = os.path.join(out_dir, "skinned_arm.glb")
    bpy.ops.export_scene.gltf(
        filepath=glb,
        export_format="GLB",
        export_animations=True,
        export_skins=True,
        export_apply=False,
        export_cameras=True,
        export_lights=True,
    )
    with open(os.path.join(out_dir, "skinned_arm.json"), "w") as f:
        json.dump({"frames": frames}, f, indent=1)


if __name__ == "__main__":
    main()
