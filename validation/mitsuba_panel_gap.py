#!/usr/bin/env python3
"""A panel hung 5 cm under a ceiling (the near field of direct light), shrad against Mitsuba 3.

A closed 4 x 3 x 4 m room of reflectance 0.7 and a 0.5 m black panel (radiance 254.65 a
side, 200 W down) 5 cm under its ceiling, lit one-sided (down) or two-sided (up too, into
the gap), as Blender exports a panel (every material double-sided). The camera looks at the
back wall and does not see the panel. Mitsuba 3 (scalar_rgb, `path`, 1024 spp) and shrad's
reference solver at several patch counts render it at 160 x 120; the table is the mean
linear radiance and shrad / Mitsuba (docs/results.md §6, "A seventh pass").

    python validation/mitsuba_panel_gap.py --shrad target/release/shrad [--patches 3000,8000,32000]

(the venv of validation/setup-venv.sh has Mitsuba; the renders go to target/panel-gap/).
"""
from __future__ import annotations

import argparse
import subprocess
from pathlib import Path

import mitsuba as mi
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
L = 254.6479
SCENE = """[camera]
eye = [0, 1.5, 1.9]
target = [0, 1.5, 0]
yfov_deg = 55

[[object]]
name = "room"
shape = "box"
size = [4, 3, 4]
position = [0, 1.5, 0]
inward = true
reflectance = [0.7, 0.7, 0.7]

[[object]]
name = "panel"
role = "light"
shape = "quad"
corners = [[-0.25, 2.95, -0.25], [0.25, 2.95, -0.25], [0.25, 2.95, 0.25], [-0.25, 2.95, 0.25]]
reflectance = [0, 0, 0]
emission = [{L}, {L}, {L}]
double_sided = {two}
"""


def mitsuba_mean(two_sided: bool, spp: int) -> float:
    mi.set_variant("scalar_rgb")
    t = mi.ScalarTransform4f

    def diffuse(r):
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": [r, r, r]}}

    def rect(to_world, r, emit=False):
        d = {"type": "rectangle", "to_world": to_world, "bsdf": diffuse(r)}
        if emit:
            d["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": [L, L, L]}}
        return d

    # A rectangle is [-1, 1]^2 in xy, facing +z; every wall faces into the room.
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 64},
        "sensor": {
            "type": "perspective", "fov": 55.0, "fov_axis": "y",
            "to_world": t().look_at(origin=[0, 1.5, 1.9], target=[0, 1.5, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 160, "height": 120, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "floor": rect(t().rotate([1, 0, 0], -90).scale([2, 2, 1]), 0.7),
        "ceiling": rect(t().translate([0, 3, 0]).rotate([1, 0, 0], 90).scale([2, 2, 1]), 0.7),
        "back": rect(t().translate([0, 1.5, -2]).scale([2, 1.5, 1]), 0.7),
        "front": rect(t().translate([0, 1.5, 2]).rotate([0, 1, 0], 180).scale([2, 1.5, 1]), 0.7),
        "left": rect(t().translate([-2, 1.5, 0]).rotate([0, 1, 0], 90).scale([2, 1.5, 1]), 0.7),
        "right": rect(t().translate([2, 1.5, 0]).rotate([0, 1, 0], -90).scale([2, 1.5, 1]), 0.7),
        "down": rect(t().translate([0, 2.95, 0]).rotate([1, 0, 0], 90).scale([0.25, 0.25, 1]), 0.0, True),
    }
    if two_sided:
        up = t().translate([0, 2.95 + 1e-5, 0]).rotate([1, 0, 0], -90).scale([0.25, 0.25, 1])
        scene["up"] = rect(up, 0.0, True)
    return float(np.array(mi.render(mi.load_dict(scene))).mean())


def shrad_mean(shrad: str, two_sided: bool, patches: int, out: Path) -> float:
    toml = out / f"panel-{'two' if two_sided else 'one'}.toml"
    toml.write_text(SCENE.format(L=L, two="true" if two_sided else "false"))
    exr = out / f"{toml.stem}-{patches}.exr"
    subprocess.run([shrad, "render", str(toml), "--patches", str(patches), "--width", "160",
                    "--height", "120", "--hdr", str(exr), "-o", str(exr.with_suffix(".png")),
                    "--quiet"], check=True)
    mi.set_variant("scalar_rgb")
    return float(np.array(mi.Bitmap(str(exr))).mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shrad", default=str(ROOT / "target/release/shrad"))
    ap.add_argument("--patches", default="3000,8000,32000")
    ap.add_argument("--spp", type=int, default=1024)
    args = ap.parse_args()
    out = ROOT / "target/panel-gap"
    out.mkdir(parents=True, exist_ok=True)
    print("| panel | Mitsuba | patches | shrad (reference) | shrad / Mitsuba |")
    print("|---|---:|---:|---:|---:|")
    for two in (False, True):
        m = mitsuba_mean(two, args.spp)
        for n in (int(p) for p in args.patches.split(",")):
            s = shrad_mean(args.shrad, two, n, out)
            side = "two-sided" if two else "one-sided"
            print(f"| {side} | {m:.4f} | {n} | {s:.4f} | {s / m:.4f} |")


if __name__ == "__main__":
    main()
