#!/usr/bin/env python3
"""shrad's lights and sky against Mitsuba 3 (scalar_rgb, `path` integrator).

One small open scene of quads (a 6 x 6 floor, a back wall, a box), lit in turn by each light
kind shrad takes: a point, a spot and a directional light (`[[lights]]`), a constant sky and
an environment map with a small bright sun (`[environment]`). Each is written as a shrad
scene file and as a Mitsuba dict with the same geometry, camera and emitter, rendered at
256 x 256 by Mitsuba and by shrad (the reference solver and the dispersive default), and
compared: relative RMSE of 8 x 8 pixel block means of linear radiance (RGB), and the mean
radiance ratio shrad / Mitsuba.

Run on demand (minutes; not part of the test suite), through validation/lights.sh:

    validation/lights.sh [--spp 256] [--cases point,spot,...]
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

EYE = (0.0, 4.2, 5.4)
TARGET = (0.0, 0.3, 0.0)
YFOV = 40.0
W = H = 256

# Quads: (name, corners counter-clockwise seen from the front, reflectance).
A = 3.0
S = 0.4  # box half-size
BX, BZ = 0.2, -0.3  # box centre on the floor
QUADS = [
    ("floor", [(-A, 0, -A), (-A, 0, A), (A, 0, A), (A, 0, -A)], (0.7, 0.7, 0.7)),
    ("wall", [(-A, 0, -A), (A, 0, -A), (A, 2.0, -A), (-A, 2.0, -A)], (0.6, 0.5, 0.4)),
]


def box_quads():
    x0, x1, z0, z1, h = BX - S, BX + S, BZ - S, BZ + S, 2 * S
    rho = (0.7, 0.3, 0.2)
    return [
        ("box_top", [(x0, h, z0), (x0, h, z1), (x1, h, z1), (x1, h, z0)], rho),
        ("box_front", [(x0, 0, z1), (x1, 0, z1), (x1, h, z1), (x0, h, z1)], rho),
        ("box_back", [(x1, 0, z0), (x0, 0, z0), (x0, h, z0), (x1, h, z0)], rho),
        ("box_left", [(x0, 0, z0), (x0, 0, z1), (x0, h, z1), (x0, h, z0)], rho),
        ("box_right", [(x1, 0, z1), (x1, 0, z0), (x1, h, z0), (x1, h, z1)], rho),
    ]


def all_quads():
    return QUADS + box_quads()


SPOT_FROM, SPOT_TO = (0.8, 2.6, 1.0), (0.2, 0.0, -0.2)
SUN_DIR = (-1.0, -2.0, -0.6)
SKY = (0.5, 0.6, 0.8)
ENV_ROTATE = 60.0


def env_map(path: Path) -> None:
    """A 256 x 128 map: a sky brighter towards the zenith, a dim ground, a small sun."""
    import mitsuba as mi

    w, h = 256, 128
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    theta = np.pi * v[:, None] * np.ones((1, w))
    phi = 2 * np.pi * u[None, :] * np.ones((h, 1))
    up = np.cos(theta)
    img = np.zeros((h, w, 3), np.float32)
    sky = np.stack([0.25 + 0.2 * up, 0.35 + 0.3 * up, 0.6 + 0.4 * up], -1)
    ground = np.array([0.12, 0.1, 0.08])
    img[:] = np.where(up[..., None] > 0, sky, ground)
    # The sun: 40 degrees from the zenith, about 1.5 degrees across.
    st, sp = math.radians(40.0), 0.3 * 2 * np.pi
    d = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)
    s = np.array([math.sin(sp) * math.sin(st), math.cos(st), -math.cos(sp) * math.sin(st)])
    img[(d @ s) > math.cos(math.radians(1.5))] = (3000.0, 2800.0, 2500.0)
    mi.Bitmap(img).write(str(path))


def toml_scene(case: str, env: Path) -> str:
    out = [
        f"[camera]\neye = {list(EYE)}\ntarget = {list(TARGET)}\nyfov_deg = {YFOV}\n",
        "[settings]\npatches = 8000\n",
    ]
    for name, c, rho in all_quads():
        role = "interior" if name.startswith("box") else "boundary"
        out.append(
            f'[[object]]\nname = "{name}"\nshape = "quad"\nrole = "{role}"\n'
            f"corners = {[list(p) for p in c]}\nreflectance = {list(rho)}\n"
        )
    if case == "point":
        out.append('[[lights]]\nkind = "point"\nposition = [0.9, 1.6, 0.5]\n'
                   f"power = {4 * math.pi * 2.0}\n")  # 2 W/sr
    elif case == "spot":
        d = [b - a for a, b in zip(SPOT_FROM, SPOT_TO)]
        out.append(f'[[lights]]\nkind = "spot"\nposition = {list(SPOT_FROM)}\ndirection = {d}\n'
                   f"intensity = {4.0 * 683.0}\ninner_cone_deg = 29\nouter_cone_deg = 30\n")
    elif case == "directional":
        out.append(f'[[lights]]\nkind = "directional"\ndirection = {list(SUN_DIR)}\nirradiance = 3.0\n')
    elif case == "constant":
        out.append(f"[environment]\nradiance = {list(SKY)}\n")
    elif case == "envmap":
        out.append(f'[environment]\nfile = "{env.name}"\nrotate_deg = {ENV_ROTATE}\n')
    return "\n".join(out)


def mitsuba_dict(case: str, env: Path, spp: int, tmp: Path) -> dict:
    import mitsuba as mi

    T = mi.ScalarTransform4f
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 64, "rr_depth": 64, "hide_emitters": False},
        "sensor": {
            "type": "perspective", "fov": YFOV, "fov_axis": "y",
            "to_world": T().look_at(origin=EYE, target=TARGET, up=(0, 1, 0)),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"},
                     "pixel_format": "rgb", "component_format": "float32"},
        },
    }
    for name, c, rho in all_quads():
        fn = tmp / f"{name}.obj"
        fn.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in c) + "f 1 2 3\nf 1 3 4\n")
        d[name] = {"type": "obj", "filename": str(fn), "face_normals": True,
                   "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rho)}}}
    rgb = lambda v: {"type": "rgb", "value": list(v)}  # noqa: E731
    if case == "point":
        d["light"] = {"type": "point", "position": [0.9, 1.6, 0.5], "intensity": rgb((2.0,) * 3)}
    elif case == "spot":
        d["light"] = {"type": "spot", "to_world": T().look_at(origin=SPOT_FROM, target=SPOT_TO, up=(0, 0, 1)),
                      "intensity": rgb((4.0,) * 3), "cutoff_angle": 30.0, "beam_width": 29.0}
    elif case == "directional":
        d["light"] = {"type": "directional", "direction": list(SUN_DIR), "irradiance": rgb((3.0,) * 3)}
    elif case == "constant":
        d["light"] = {"type": "constant", "radiance": rgb(SKY)}
    elif case == "envmap":
        d["light"] = {"type": "envmap", "filename": str(env),
                      "to_world": T().rotate(axis=(0, 1, 0), angle=ENV_ROTATE)}
    return d


def read_exr(path: Path) -> np.ndarray:
    import mitsuba as mi

    return np.array(mi.Bitmap(str(path)), dtype=np.float64)[:, :, :3]


def blocks(img: np.ndarray, b: int) -> np.ndarray:
    h, w, c = img.shape
    return img[: h - h % b, : w - w % b].reshape(h // b, b, w // b, b, c).mean(axis=(1, 3))


def rel_rmse(a: np.ndarray, ref: np.ndarray) -> float:
    return float(np.sqrt(np.sum((a - ref) ** 2) / np.sum(ref**2)))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--shrad", default=str(ROOT / "target/release/shrad"))
    ap.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel")
    ap.add_argument("--cases", default="point,spot,directional,constant,envmap")
    ap.add_argument("--out", default=str(ROOT / "target/validation-lights"))
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    env = out / "sky.exr"
    env_map(env)
    rows = []
    for case in args.cases.split(","):
        scene = out / f"{case}.toml"
        scene.write_text(toml_scene(case, env))
        ref_path = out / f"{case}_mitsuba_{args.spp}.exr"
        if not ref_path.exists():
            t0 = time.time()
            img = mi.render(mi.load_dict(mitsuba_dict(case, env, args.spp, out)), spp=args.spp)
            mi.Bitmap(img).write(str(ref_path))
            print(f"{case}: Mitsuba {args.spp} spp in {time.time() - t0:.0f} s", flush=True)
        ref = read_exr(ref_path)
        row = [case]
        for tag, solver in (("reference", ["--solver", "reference"]), ("dispersive", ["--solver", "dispersive"])):
            exr = out / f"{case}_shrad_{tag}.exr"
            cmd = [args.shrad, "render", str(scene), *solver, "--width", str(W), "--height", str(H),
                   "--spp", "4", "-o", str(out / f"{case}_shrad_{tag}.png"), "--hdr", str(exr), "--quiet"]
            subprocess.run(cmd, check=True)
            img = read_exr(exr)
            e = rel_rmse(blocks(img, 8), blocks(ref, 8))
            ratio = img.mean(axis=(0, 1)) / ref.mean(axis=(0, 1))
            row.append((e, ratio))
            print(f"{case} {tag}: block RMSE {100 * e:.2f} %, mean ratio {np.round(ratio, 4)}", flush=True)
        rows.append(row)
    print("\n| light | reference | dispersive default | mean ratio (reference, RGB) |")
    print("|---|---|---|---|")
    for case, (er, rr), (ed, _) in rows:
        print(f"| {case} | {100 * er:.2f} % | {100 * ed:.2f} % | {', '.join(f'{x:.3f}' for x in rr)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
