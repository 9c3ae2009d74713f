#!/usr/bin/env python3
"""Build an animated room in Blender the way users do and export it with Blender's own glTF
exporter, then print Blender's world matrix of every object at a few times (JSON), so
shrad's glTF animation import can be checked against Blender (issue 10).

The scene (24 fps, frames 1..48): a room (a scaled cube with flipped normals), an emissive
ceiling panel, a box "mover" that slides across the floor and turns (keys on location and
rotation at frames 1, 24, 48, Blender's default Bezier interpolation), a "rider" cube
parented to it, and a "pulser" sphere with scale keys.

    /tmp/bpyenv/bin/python validation/blender_animation.py OUT_DIR [--cubic]

writes OUT_DIR/animated_room.glb (sampled: LINEAR keys at every frame, the exporter's
default) and, with --cubic, OUT_DIR/animated_room_cubic.glb (not sampled: Bezier keys as
CUBICSPLINE), and OUT_DIR/animated_room.json: for each object and sample time, Blender's
matrix_world converted to glTF's +Y-up axes (M_gltf = C M_blender C^-1, C: (x, y, z) ->
(x, z, -y)), row-major 4x4. Times are scene times t = (frame - frame_start) / fps, the
times shrad plays (the exporter slides the animation to start at 0, see below).
"""
import json
import math
import os
import sys

import bpy  # noqa: E402


FPS = 24
FRAMES = (1, 48)
# Frames at which Blender's pose is recorded; 12.5 and 30.25 fall between the exporter's
# per-frame samples (Blender's Bezier there, shrad's interpolation of the samples).
SAMPLE_FRAMES = [1, 6, 12, 12.5, 24, 30.25, 36, 47, 48]


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


def key(obj, frame, **props):
    for name, value in props.items():
        setattr(obj, name, value)
        obj.keyframe_insert(data_path=name, frame=frame)


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.frame_start, scene.frame_end = FRAMES
    # The room: a 2 m cube scaled (not applied) to 4 x 5 x 3 m, normals turned inward.
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0, 0, 1.5))
    room = bpy.context.active_object
    room.name = "room"
    room.scale = (2.0, 2.5, 1.5)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode="OBJECT")
    room.data.materials.append(material("walls", (0.7, 0.68, 0.65)))
    # A ceiling panel light facing down.
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0, 0, 2.99))
    light = bpy.context.active_object
    light.name = "light"
    light.scale = (0.5, 0.3, 1.0)
    light.rotation_euler = (math.pi, 0, 0)
    light.data.materials.append(material("panel", (0.0, 0.0, 0.0), emit=((1.0, 0.9, 0.8), 20.0)))
    # The mover: a 0.5 m box sliding and turning.
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(-1.2, -1.0, 0.25))
    mover = bpy.context.active_object
    mover.name = "mover"
    mover.data.materials.append(material("red", (0.8, 0.1, 0.08)))
    key(mover, 1, location=(-1.2, -1.0, 0.25), rotation_euler=(0.0, 0.0, 0.0))
    key(mover, 24, location=(0.0, 0.6, 0.25), rotation_euler=(0.0, 0.0, math.radians(90)))
    key(mover, 48, location=(1.1, 1.2, 0.6), rotation_euler=(math.radians(20), 0.0, math.radians(200)))
    # The rider: a small cube on top of the mover, parented to it (moves with it), with a
    # rest offset in the mover's frame.
    bpy.ops.mesh.primitive_cube_add(size=0.2, location=(0, 0, 0))
    rider = bpy.context.active_object
    rider.name = "rider"
    rider.data.materials.append(material("yellow", (0.8, 0.7, 0.1)))
    rider.parent = mover
    rider.location = (0.15, 0.0, 0.35)
    rider.rotation_euler = (0.0, 0.0, math.radians(30))
    # The pulser: a sphere whose scale changes (non-uniform at the middle key).
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.3, segments=16, ring_count=8, location=(1.0, -1.2, 0.5))
    pulser = bpy.context.active_object
    pulser.name = "pulser"
    pulser.data.materials.append(material("blue", (0.1, 0.2, 0.8)))
    key(pulser, 1, scale=(1.0, 1.0, 1.0))
    key(pulser, 24, scale=(1.6, 1.0, 0.6))
    key(pulser, 48, scale=(0.7, 0.7, 0.7))
    scene.frame_set(FRAMES[0])
    return scene


# Blender +Z up -> glTF +Y up: (x, y, z) -> (x, z, -y).
C = [[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]
C_INV = [[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def poses(scene):
    out = {}
    for f in SAMPLE_FRAMES:
        whole = int(math.floor(f))
        scene.frame_set(whole, subframe=f - whole)
        t = (f - FRAMES[0]) / FPS
        for o in scene.objects:
            if o.type != "MESH":
                continue
            m = [list(row) for row in o.matrix_world]
            out.setdefault(o.name, []).append({"frame": f, "time": t, "matrix": mul(mul(C, m), C_INV)})
    scene.frame_set(FRAMES[0])
    return out


def export(path, sampled):
    # export_anim_slide_to_zero: the animation's first frame is t = 0, as the times above.
    bpy.ops.export_scene.gltf(
        filepath=path,
        export_format="GLB",
        export_apply=False,
        export_yup=True,
        export_animations=True,
        export_frame_range=True,
        export_anim_slide_to_zero=True,
        export_force_sampling=sampled,
        export_animation_mode="ACTIONS",
    )


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    out = args[-1] if args else "."
    os.makedirs(out, exist_ok=True)
    scene = build()
    record = {"fps": FPS, "frames": FRAMES, "objects": poses(scene)}
    export(os.path.join(out, "animated_room.glb"), sampled=True)
    if "--cubic" in sys.argv:
        export(os.path.join(out, "animated_room_cubic.glb"), sampled=False)
    with open(os.path.join(out, "animated_room.json"), "w") as f:
        json.dump(record, f, indent=1)
    print(json.dumps({k: len(v) for k, v in record["objects"].items()}))


main()
