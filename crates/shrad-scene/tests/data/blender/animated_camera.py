#!/usr/bin/env python3
"""A camera that an animation moves, exported by Blender's own glTF exporter, with Blender's
camera pose at a few frames (JSON), to check `Scene::camera_at` against Blender.

The scene (24 fps, frames 1..48): a floor plane, a "dolly" empty that slides and turns
(location and rotation keys at frames 1, 24, 48, Bezier), and the camera parented to it at a
rest offset, tilted down; the camera itself has a location key pair (it rises).

    /tmp/bpyenv/bin/python crates/shrad-scene/tests/data/blender/animated_camera.py OUT_DIR

writes OUT_DIR/animated_camera.glb (sampled, LINEAR keys every frame) and
OUT_DIR/animated_camera.json: for each sample time t = (frame - 1) / fps, the camera's world
matrix in glTF's +Y-up axes, C * matrix_world (C: (x, y, z) -> (x, z, -y); a camera looks
down its local -Z with +Y up in Blender and glTF alike, so no correction on the right),
row-major 4x4.
"""
import json
import math
import os
import sys

import bpy

FPS = 24
FRAMES = (1, 48)
SAMPLE_FRAMES = [1, 7, 12.5, 24, 30.25, 40, 48]
C = [[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def key(obj, frame, **props):
    for name, value in props.items():
        setattr(obj, name, value)
        obj.keyframe_insert(data_path=name, frame=frame)


def build():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.frame_start, scene.frame_end = FRAMES
    bpy.ops.mesh.primitive_plane_add(size=6.0, location=(0, 0, 0))
    bpy.context.active_object.name = "floor"
    bpy.ops.object.empty_add(location=(0, -4, 0))
    dolly = bpy.context.active_object
    dolly.name = "dolly"
    key(dolly, 1, location=(0.0, -4.0, 0.0), rotation_euler=(0.0, 0.0, 0.0))
    key(dolly, 24, location=(2.0, -3.0, 0.0), rotation_euler=(0.0, 0.0, math.radians(40)))
    key(dolly, 48, location=(3.0, 0.0, 0.5), rotation_euler=(0.0, 0.0, math.radians(90)))
    cam_data = bpy.data.cameras.new("lens")
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.parent = dolly
    cam.location = (0.0, 0.0, 1.5)
    cam.rotation_euler = (math.radians(75), 0.0, 0.0)  # looks along +Y, tilted down 15 deg
    key(cam, 1, location=(0.0, 0.0, 1.5))
    key(cam, 48, location=(0.0, 0.0, 2.5))
    scene.frame_set(FRAMES[0])
    return scene, cam


def main():
    out = [a for a in sys.argv[1:] if not a.startswith("--")][-1]
    os.makedirs(out, exist_ok=True)
    scene, cam = build()
    poses = []
    for f in SAMPLE_FRAMES:
        whole = int(math.floor(f))
        scene.frame_set(whole, subframe=f - whole)
        m = [list(row) for row in cam.matrix_world]
        poses.append({"frame": f, "time": (f - FRAMES[0]) / FPS, "matrix": mul(C, m)})
    scene.frame_set(FRAMES[0])
    bpy.ops.export_scene.gltf(
        filepath=os.path.join(out, "animated_camera.glb"),
        export_format="GLB",
        export_yup=True,
        export_cameras=True,
        export_animations=True,
        export_frame_range=True,
        export_anim_slide_to_zero=True,
        export_force_sampling=True,
        export_animation_mode="ACTIONS",
    )
    with open(os.path.join(out, "animated_camera.json"), "w") as fh:
        json.dump({"fps": FPS, "frames": FRAMES, "camera": poses}, fh, indent=1)


main()
