#!/usr/bin/env python3
"""Blender's skinned arm through shrad, frame by frame: the scene of
`crates/shrad-scene/tests/data/blender/skinned_arm.py` (an upright box arm skinned to a
two-bone armature whose rotations are keyed, every vertex wholly one bone's), exported once
with its skin and animation, and once still at each of some frames with the armature
applied (Blender's deformed mesh, no skin). shrad renders the animated file at each
frame's time (`shrad render --time`), where it moves the skinned mesh as rigid parts, one
per joint, and the still export of that frame, at the still one's exposure; the two
pictures must agree but at the elbow, where the rigid parts open along one ring.

    /tmp/bpyenv/bin/pip install bpy==5.0.1 pillow
    /tmp/bpyenv/bin/python validation/blender_skinned_arm.py OUT_DIR
        [--frames 1,13,25,37,49] [--shrad ./target/release/shrad] [--patches 20000]

Prints one JSON line per (frame, solver): the mean absolute difference of the two 8-bit
pictures and the share of pixels that differ by more than 8 of 255; writes the PNGs to
OUT_DIR and `arm_frames.png` (the animated renders of the dispersive default side by side,
frames 1, 25 and 49, docs/images/blender_skinned_arm.png).
Results: docs/validation.md, "A skinned arm from Blender".
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
FIXTURE = ROOT / "crates/shrad-scene/tests/data/blender/skinned_arm.py"


def render(shrad, args, png, solver, patches, exposure=None):
    """Render with shrad; returns the exposure it used."""
    cmd = [shrad, "render", *args, "--solver", solver, "--patches", patches, "-o", str(png)]
    if exposure is not None:
        cmd += ["--exposure", exposure]
    run = subprocess.run(cmd, capture_output=True, text=True, check=True)
    lines = run.stdout.splitlines() + run.stderr.splitlines()
    return next(l.split()[1] for l in lines if l.startswith("exposure"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--frames", default="1,13,25,37,49")
    ap.add_argument("--shrad", default=str(ROOT / "target/release/shrad"))
    ap.add_argument("--patches", default="20000")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    sys.argv = ["skinned_arm.py", str(out)]
    runpy.run_path(str(FIXTURE), run_name="__main__")
    scene = bpy.context.scene
    animated = out / "skinned_arm.glb"
    for frame in [int(f) for f in a.frames.split(",")]:
        scene.frame_set(frame)
        still = out / f"still_{frame}.glb"
        bpy.ops.export_scene.gltf(filepath=str(still), export_format="GLB",
                                  export_lights=True, export_cameras=True,
                                  export_animations=False, export_skins=False,
                                  export_apply=True, export_current_frame=True)
        t = frame / scene.render.fps
        for solver in ("reference", "dispersive"):
            pngs = {name: out / f"{name}_{frame}_{solver}.png" for name in ("still", "animated")}
            exposure = render(a.shrad, [str(still)], pngs["still"], solver, a.patches)
            render(a.shrad, [str(animated), "--time", str(t)], pngs["animated"], solver,
                   a.patches, exposure)
            pics = {k: np.asarray(Image.open(p), dtype=float) for k, p in pngs.items()}
            diff = np.abs(pics["animated"] - pics["still"]).max(axis=2)
            print(json.dumps({"frame": frame, "time": round(t, 4), "solver": solver,
                              "exposure": exposure,
                              "mean_abs_diff_8bit": round(float(diff.mean()), 3),
                              "pixels_over_8": round(float((diff > 8).mean()), 4)}),
                  flush=True)
    shown = [out / f"animated_{f}_dispersive.png" for f in (1, 25, 49)]
    if all(p.exists() for p in shown):
        ims = [Image.open(p) for p in shown]
        strip = Image.new("RGB", (sum(i.width for i in ims), ims[0].height))
        x = 0
        for im in ims:
            strip.paste(im, (x, 0))
            x += im.width
        strip.save(out / "arm_frames.png")


main()
