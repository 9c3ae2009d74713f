#!/usr/bin/env python3
"""Compare shrad's linear EXR with Cycles' for one variant.

    bpy-venv/bin/python compare.py VARIANT_DIR [--tags before,after] [--cycles cycles]

For VARIANT_DIR/full and VARIANT_DIR/direct: mean radiance ratio shrad/Cycles over the image
and over the floor, and the floor radiance binned by the angle a from the spot's axis (pixel
-> floor point from the exporter's camera: Blender's camera matrix and fov in cycles.json).
For 'direct' (walls and ceiling albedo 0, Cycles max bounces 0, so the floor shows direct light
only) also the analytic floor radiance rho/pi * I f(a) cos^3 a / h^2 with Blender's falloff
(smoothstep) and the glTF extension's (t^2). Prints a JSON summary too.
"""
import argparse, json, math, sys
from pathlib import Path
import numpy as np
import OpenEXR
sys.path.insert(0, str(Path(__file__).parent))
from glbjson import glb_json

ap = argparse.ArgumentParser()
ap.add_argument("vdir")
ap.add_argument("--tags", default="before")
ap.add_argument("--cycles", default="cycles")
ap.add_argument("--angles", default="")
a = ap.parse_args()


def exr(p):
    f = OpenEXR.File(str(p))
    ch = f.channels()
    if "RGB" in ch:
        img = ch["RGB"].pixels
    elif "RGBA" in ch:
        img = ch["RGBA"].pixels[..., :3]
    else:
        img = np.stack([ch[c].pixels for c in "RGB"], -1)
    return np.asarray(img, np.float64).mean(-1)  # grey scene: mean of RGB


def quat_mat(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def floor_geometry(glb, W, H):
    """Pixel -> floor point from the GLB's camera (what shrad uses); glTF Y up, floor y = 0."""
    j = glb_json(glb)
    cam_node = next(n for n in j["nodes"] if "camera" in n)
    spot_node = next(n for n in j["nodes"] if "extensions" in n and "KHR_lights_punctual" in n["extensions"])
    persp = j["cameras"][cam_node["camera"]]["perspective"]
    R = quat_mat(cam_node.get("rotation", [0, 0, 0, 1]))
    o = np.array(cam_node["translation"])
    ty = math.tan(persp["yfov"] / 2)
    tx = ty * W / H  # shrad: aspect from the picture size (the file's aspectRatio is W/H here)
    assert abs(persp["aspectRatio"] - W / H) < 1e-6
    jj = (np.arange(W) + 0.5) / W * 2 - 1
    ii = 1 - (np.arange(H) + 0.5) / H * 2
    X, Y = np.meshgrid(jj * tx, ii * ty)
    d = np.stack([X, Y, -np.ones_like(X)], -1) @ R.T
    t = -o[1] / d[..., 1]
    p = o + t[..., None] * d
    s = np.array(spot_node["translation"])
    hit = (d[..., 1] < 0) & (np.abs(p[..., 0]) < 3.9) & (np.abs(p[..., 2]) < 3.9)
    r = np.hypot(p[..., 0] - s[0], p[..., 2] - s[2])
    ang = np.degrees(np.arctan2(r, s[1]))
    return hit, ang, p, s[1]


def falloffs(ang_deg, size_deg, blend):
    ca = np.cos(np.radians(ang_deg))
    co = math.cos(math.radians(size_deg / 2))
    ci = math.cos(math.radians(size_deg / 2 * (1 - blend)))
    if blend > 0:
        x = np.clip((ca - co) / ((1 - co) * blend), 0, 1)
        blender = x * x * (3 - 2 * x)
    else:
        blender = (ca > co).astype(float)
    if ci > co:
        t = np.clip((ca - co) / (ci - co), 0, 1)
        gltf = t * t
    else:
        gltf = (ca > co).astype(float)
    return blender, gltf


summary = {}
vdir = Path(a.vdir)
tags = [t for t in a.tags.split(",") if t]
for kind in ("full", "direct"):
    d = vdir / kind
    if not (d / f"{a.cycles}.exr").exists():
        continue
    info = json.loads((d / f"{a.cycles}.json").read_text())
    cyc = exr(d / f"{a.cycles}.exr")
    hit, ang, p, h = floor_geometry(d / "scene.glb", cyc.shape[1], cyc.shape[0])
    size, blend = info["size"], info["blend"]
    half = size / 2
    inner = half * (1 - blend)
    if a.angles:
        samples = [float(x) for x in a.angles.split(",")]
    else:
        samples = sorted(set([0.0, round(inner * 0.5, 1), round(inner - 1, 1)] +
                             [round(inner + k * (half - inner) / 4, 1) for k in range(0, 5)] +
                             [round(half + 2, 1), round(half + 8, 1)]))
    print(f"\n=== {vdir.name}/{kind}: spot {size} deg, blend {blend} (inner {inner:.2f}, outer {half:.2f} deg)"
          f"  Cycles mean {cyc.mean():.5g}")
    res = {"cycles_mean": cyc.mean()}
    imgs = {}
    for tag in tags:
        f = d / f"shrad_{tag}.exr"
        if f.exists():
            imgs[tag] = exr(f)
            assert imgs[tag].shape == cyc.shape, (imgs[tag].shape, cyc.shape)
    for tag, im in imgs.items():
        res[tag] = dict(mean_ratio=im.mean() / cyc.mean(),
                        floor_ratio=im[hit].mean() / cyc[hit].mean(),
                        nonfloor_ratio=im[~hit].mean() / cyc[~hit].mean())
        print(f"  {tag:7s} mean ratio shrad/Cycles {res[tag]['mean_ratio']:.4f}   floor {res[tag]['floor_ratio']:.4f}"
              f"   walls/ceiling {res[tag]['nonfloor_ratio']:.4f}")
    # angle-binned profile (bins of +-0.5 deg around each sample)
    rho = info["floor"]
    I = info["power"] / (4 * math.pi)
    hdr = f"  {'a(deg)':>7s} {'npx':>5s} {'Cycles':>9s}"
    for tag in imgs:
        hdr += f" {tag+'/C':>10s}"
    if kind == "direct":
        hdr += f" {'C/anaBl':>8s} {'C/anaT2':>8s}"
        for tag in imgs:
            hdr += f" {tag+'/anaBl':>12s}"
    print(hdr)
    prof = []
    for s in samples:
        m = hit & (np.abs(ang - s) <= 0.5)
        if m.sum() < 3:
            continue
        c = cyc[m].mean()
        row = f"  {s:7.1f} {m.sum():5d} {c:9.4g}"
        ent = dict(a=s, n=int(m.sum()), cycles=c)
        for tag, im in imgs.items():
            v = im[m].mean()
            row += f" {v / c:10.3f}" if c > 1e-6 else f" {'(C=0) '+format(v,'.2g'):>10s}"
            ent[tag] = v
        if kind == "direct":
            bl, gl = falloffs(ang[m], size, blend)
            ca = np.cos(np.radians(ang[m]))
            base = rho / math.pi * I * ca ** 3 / h ** 2
            anab, anat = (base * bl).mean(), (base * gl).mean()
            row += f" {c / anab if anab > 1e-9 else float('nan'):8.3f} {c / anat if anat > 1e-9 else float('nan'):8.3f}"
            for tag, im in imgs.items():
                v = im[m].mean()
                row += f" {v / anab if anab > 1e-9 else float('nan'):12.3f}"
            ent.update(ana_blender=anab, ana_gltf=anat)
        print(row)
        prof.append(ent)
    res["profile"] = prof
    summary[kind] = res
(vdir / "compare.json").write_text(json.dumps(summary, indent=1, default=float))
