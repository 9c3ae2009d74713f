#!/usr/bin/env python3
"""A scene written by trimesh's own glTF exporter: a room (an inward box), a light panel and
boxes placed by node transforms that scale, rotate and mirror. Prints each geometry's world
area as trimesh measures it (JSON on the last line).

    python validation/trimesh_export.py OUT.glb        # needs `pip install trimesh numpy`
"""
import json
import sys

import numpy as np
import trimesh


def main():
    out = sys.argv[1]
    scene = trimesh.Scene()
    room = trimesh.creation.box(extents=(1, 1, 1))
    room.invert()  # faces inward
    room.visual.face_colors = [180, 170, 160, 255]
    scene.add_geometry(room, node_name="room", geom_name="room",
                       transform=trimesh.transformations.translation_matrix((0, 1.5, 0)) @ np.diag([4.0, 3, 5, 1]))
    panel = trimesh.creation.box(extents=(1, 0.02, 0.6))
    panel.visual.face_colors = [255, 255, 255, 255]
    scene.add_geometry(panel, node_name="panel", geom_name="panel",
                       transform=trimesh.transformations.translation_matrix((0, 2.97, 0)))
    rng = np.random.default_rng(7)
    for k, scale in enumerate([(0.3, 0.3, 0.3), (1.0, 0.5, 2.0), (-0.4, 0.8, 0.4)]):
        box = trimesh.creation.box(extents=(1, 1, 1))
        box.visual.face_colors = [int(c) for c in rng.integers(40, 220, 3)] + [255]
        t = trimesh.transformations
        m = (t.translation_matrix((rng.uniform(-1, 1), abs(scale[1]) / 2, rng.uniform(-1.5, 1.5)))
             @ t.rotation_matrix(rng.uniform(0, 6.28), (0, 1, 0))
             @ np.diag(list(np.abs(scale)) + [1.0]))
        if scale[0] < 0:
            m = m @ np.diag([-1.0, 1, 1, 1])
        scene.add_geometry(box, node_name=f"box{k}", geom_name=f"box{k}", transform=m)
    scene.export(out)
    areas = {}
    for node in scene.graph.nodes_geometry:
        m, g = scene.graph[node]
        mesh = scene.geometry[g].copy()
        mesh.apply_transform(m)
        areas[node] = float(mesh.area)
    print(json.dumps(areas))


main()
