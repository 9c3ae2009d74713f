"""Shared fixtures: small scenes, so the whole suite runs in a minute or two."""

import numpy as np
import pytest

import shrad


@pytest.fixture(scope="session")
def cornell():
    """The built-in Cornell box cut into ~1500 patches."""
    return shrad.load("cornell", patches=1500)


def box_mesh(half):
    """An axis-aligned box (outward faces) as numpy arrays: positions (24, 3), triangles (12, 3)."""
    hx, hy, hz = half
    faces = [
        [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)],  # +z
        [(1, -1, -1), (-1, -1, -1), (-1, 1, -1), (1, 1, -1)],  # -z
        [(1, -1, 1), (1, -1, -1), (1, 1, -1), (1, 1, 1)],  # +x
        [(-1, -1, -1), (-1, -1, 1), (-1, 1, 1), (-1, 1, -1)],  # -x
        [(-1, 1, 1), (1, 1, 1), (1, 1, -1), (-1, 1, -1)],  # +y
        [(-1, -1, -1), (1, -1, -1), (1, -1, 1), (-1, -1, 1)],  # -y
    ]
    pos = np.array([c for f in faces for c in f], dtype=np.float32) * np.array([hx, hy, hz], np.float32)
    tris = []
    for f in range(6):
        b = 4 * f
        tris += [[b, b + 1, b + 2], [b, b + 2, b + 3]]
    return pos, np.array(tris, dtype=np.int64)


def room_dict(patches=1200, keyframes=False):
    """A closed room with a ceiling light and a numpy-mesh block inside."""
    pos, tris = box_mesh((0.3, 0.3, 0.3))
    block = {
        "name": "block",
        "shape": "mesh",
        "positions": pos,
        "triangles": tris,
        "reflectance": [0.6, 0.5, 0.4],
        "position": [-0.6, 0.3, 0.0],
    }
    if keyframes:
        block["key"] = [
            {"time": 0.0, "translation": [0.0, 0.0, 0.0]},
            {"time": 1.0, "translation": [1.2, 0.0, 0.0], "rotation_deg": [0, 45, 0]},
        ]
    return {
        "name": "py-room",
        "settings": {"patches": patches},
        "camera": {"eye": [0, 1.2, -1.9], "target": [0, 1.0, 0], "yfov_deg": 60},
        "objects": [
            {
                "name": "room",
                "shape": "box",
                "size": [3, 2.5, 4],
                "inward": True,
                "role": "boundary",
                "position": [0, 1.25, 0],
                "reflectance": [0.7, 0.7, 0.7],
            },
            {
                "name": "lamp",
                "shape": "quad",
                "corners": [[-0.4, 2.49, -0.4], [0.4, 2.49, -0.4], [0.4, 2.49, 0.4], [-0.4, 2.49, 0.4]],
                "emission": [8, 8, 8],
            },
            block,
        ],
    }
