#!/usr/bin/env python3
"""Blender's animated lamps and glow through shrad, frame by frame: the scene of
`crates/shrad-scene/tests/data/blender/animated_lights.py` (a point lamp whose power and
colour are keyed and which moves, a spot whose size and blend are keyed, a cube whose
emission strength is keyed), exported once with its animation ("Animation Pointer" on:
KHR_animation_pointer) and once still at each of some frames (Blender's static export,
which validation/blender_lights.py checks against Cycles). shrad renders the animated file
at each frame's time (`shrad render --time`) and the still export of that frame; the two
pictures must agree. Blender's exporter writes the keyed power 4 pi too bright and the
keyed blend as the inner cone's keys; shrad reads them as Blender means them
(`gltf_io/blender_quirks.rs`), so that they do.

    /tmp/bpyenv/bin/pip install bpy==5.0.1 pillow
    /tmp/bpyenv/bin/python validation/blender_animated_lights.py OUT_DIR
        [--frames 1,13,25,37,49] [--shrad ./target/release/shrad] [--patches 20000]

Prints one JSON line per (frame, solver): the mean absolute difference of the two 8-bit
pictures (at one exposure, the still one's) and the largest; writes the PNGs to OUT_DIR.
Results: docs/validation.md, "Animated lamps from Blender".
"""
import argparse
import json
import runpy
import subprocess
import sys
from pathlib import Path

import bpy  # noqa: F401  (the fixture script builds the scene with it)
import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
FIXTURE = ROOT / "crates/shrad-scene/tests/data/blender/animated_lights.py"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--frames", default="1,13,25,37,49")
    ap.add_argument("--shrad", default=str(ROOT / "target/release/shrad"))
    ap.add_argument("--patches", default="20000")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    sys.argv = ["animated_lights.py", str(out)]
    runpy.run_path(str(FIXTURE), run_name="__main__")
    scene = bpy.context.scene
    for frame in [int(f) for f in a.frames.split(",")]:
        scene.frame_set(frame)
        still = out / f"still_{frame}.glb"
        bpy.ops.export_scene.gltf(filepath=str(still), export_format="GLB",
                                  export_lights=True, export_cameras=True,
                                  export_animations=False,
                                  export_current_frame=True)
        t = frame / scene.render.fps
        for solver in ("reference", "dispersive"):
            pics = {}
            for name, args in (("still", [str(still)]),
                               ("animated", [str(out / "animated_lights.glb"), "--time", str(t)])):
                png = out / f"{name}_{frame}_{solver}.png"
                run = subprocess.run([a.shrad, "render", *args, "--solver", solver,
                                      "--patches", a.patches, "-o", str(png)],
                                     capture_output=True, text=True, check=True)
                exposure = [l for l in run.stdout.splitlines() + run.stderr.splitlines()
                            if l.startswith("exposure")]
                pics[name] = (np.asarray(Image.open(png), dtype=float), exposure)
            diff = np.abs(pics["animated"][0] - pics["still"][0])
            print(json.dumps({"frame": frame, "time": round(t, 4), "solver": solver,
                              "mean_abs_diff_8bit": round(float(diff.mean()), 4),
                              "max_abs_diff_8bit": float(diff.max()),
                              "exposures": [pics["still"][1], pics["animated"][1]]}),
                  flush=True)


main()
