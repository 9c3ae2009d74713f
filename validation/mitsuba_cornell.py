#!/usr/bin/env python3
"""Independent validation of shrad against the Mitsuba 3 path tracer on the Cornell box.

Renders scenes/cornell.obj (+ .mtl, written by shrad from its built-in `cornell`) with
Mitsuba 3 (`scalar_rgb`, `path` integrator, diffuse BSDFs, area light) using shrad's
camera, renders the same scene with shrad (`shrad render cornell --hdr ...`) at several
settings, and compares the linear images: block-averaged relative RMSE of RGB radiance,
overall and per region, plus the mean radiance ratio shrad/mitsuba per channel.

Run on demand (slow: minutes), not part of the test suite. See docs/validation.md.

    python validation/mitsuba_cornell.py [--spp 1024] [--shrad target/release/shrad]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

# shrad's built-in camera (crates/shrad-scene/src/builtin.rs, cornell_box()).
CAM_ORIGIN = (278.0, 273.0, -800.0)
CAM_TARGET = (278.0, 273.0, 0.0)
CAM_UP = (0.0, 1.0, 0.0)
CAM_YFOV_DEG = 39.3077

WALLS = ("floor", "ceiling", "back", "left_red", "right_green")
BLOCKS = ("short_block", "tall_block")


# --------------------------------------------------------------------------------------
# Scene: the OBJ/MTL shrad exported, split per object
# --------------------------------------------------------------------------------------
def read_mtl(path: Path) -> dict[str, dict[str, tuple[float, float, float]]]:
    mats: dict[str, dict] = {}
    cur = None
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        if parts[0] == "newmtl":
            cur = mats.setdefault(parts[1], {"Kd": (0.0, 0.0, 0.0), "Ke": (0.0, 0.0, 0.0)})
        elif cur is not None and parts[0] in ("Kd", "Ke"):
            vals = [float(v) for v in parts[1:4]]
            if len(vals) == 1:
                vals = vals * 3
            cur[parts[0]] = tuple(vals)
    return mats


def read_obj(path: Path) -> list[dict]:
    """Objects of a triangle/polygon OBJ: name, material, world positions, triangles."""
    verts: list[tuple[float, float, float]] = []
    objects: list[dict] = []
    cur = None
    mat = None
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        key = parts[0]
        if key == "v":
            verts.append(tuple(float(v) for v in parts[1:4]))
        elif key in ("o", "g"):
            cur = {"name": parts[1] if len(parts) > 1 else f"obj{len(objects)}", "material": mat, "faces": []}
            objects.append(cur)
        elif key == "usemtl":
            mat = parts[1]
            if cur is not None:
                cur["material"] = mat
        elif key == "f":
            if cur is None:
                cur = {"name": f"obj{len(objects)}", "material": mat, "faces": []}
                objects.append(cur)
            idx = []
            for tok in parts[1:]:
                i = int(tok.split("/")[0])
                idx.append(i - 1 if i > 0 else len(verts) + i)
            for k in range(1, len(idx) - 1):  # fan, keeps the winding
                cur["faces"].append((idx[0], idx[k], idx[k + 1]))
    out = []
    for o in objects:
        if not o["faces"]:
            continue
        used = sorted({i for f in o["faces"] for i in f})
        remap = {old: new for new, old in enumerate(used)}
        out.append(
            {
                "name": o["name"],
                "material": o["material"],
                "positions": np.array([verts[i] for i in used], dtype=np.float64),
                "triangles": np.array([[remap[i] for i in f] for f in o["faces"]], dtype=np.int64),
            }
        )
    return out


def check_orientation(objects: list[dict]) -> list[str]:
    """Sanity checks of the front sides shrad uses: walls face into the box, the light
    faces down, blocks are closed with outward normals (positive signed volume)."""
    notes = []
    centre = np.array([278.0, 274.4, 279.6])
    for o in objects:
        p, t = o["positions"], o["triangles"]
        a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
        n = np.cross(b - a, c - a)
        if o["name"] in WALLS:
            inward = np.einsum("ij,ij->i", n, centre - (a + b + c) / 3) > 0
            notes.append(f"{o['name']}: {'faces inward' if inward.all() else 'NOT all inward!'}")
        elif o["name"] == "light":
            notes.append(f"light: normal y sign {np.sign(n[:, 1]).tolist()} (want -1: facing down)")
        else:
            vol = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0
            notes.append(f"{o['name']}: signed volume {vol:.4g} ({'outward' if vol > 0 else 'INWARD!'})")
    return notes


def write_obj(path: Path, o: dict) -> None:
    with open(path, "w") as f:
        for v in o["positions"]:
            f.write(f"v {float(v[0])!r} {float(v[1])!r} {float(v[2])!r}\n")
        for t in o["triangles"]:
            f.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")


# --------------------------------------------------------------------------------------
# Mitsuba
# --------------------------------------------------------------------------------------
def mitsuba_scene_dict(objects, mats, tmpdir: Path, width: int, height: int, spp: int, seed: int = 0,
                       max_depth: int = 64, rr_depth: int = 64):
    import mitsuba as mi

    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": rr_depth, "hide_emitters": False},
        "sensor": {
            "type": "perspective",
            "fov": CAM_YFOV_DEG,
            "fov_axis": "y",
            "near_clip": 1.0,
            "far_clip": 1e5,
            "to_world": mi.ScalarTransform4f.look_at(origin=CAM_ORIGIN, target=CAM_TARGET, up=CAM_UP),
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
            "film": {
                "type": "hdrfilm",
                "width": width,
                "height": height,
                "rfilter": {"type": "box"},  # a pixel's value = mean over its square, like shrad
                "pixel_format": "rgb",
                "component_format": "float32",
            },
        },
    }
    for o in objects:
        m = mats.get(o["material"], {"Kd": (0.0, 0.0, 0.0), "Ke": (0.0, 0.0, 0.0)})
        fn = tmpdir / f"{o['name']}.obj"
        write_obj(fn, o)
        shape = {
            "type": "obj",
            "filename": str(fn),
            "face_normals": True,  # flat: normals from the triangle winding (CCW = front)
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(m["Kd"])}},
        }
        if max(m["Ke"]) > 0:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": list(m["Ke"])}}
        d[o["name"]] = shape
    return d


def render_mitsuba(objects, mats, width, height, spp, seed, tmpdir: Path) -> tuple[np.ndarray, float]:
    import mitsuba as mi

    scene = mi.load_dict(mitsuba_scene_dict(objects, mats, tmpdir, width, height, spp, seed))
    t0 = time.time()
    img = mi.render(scene, spp=spp, seed=seed)
    dt = time.time() - t0
    return np.array(img, dtype=np.float64)[:, :, :3], dt


def object_ids(objects, mats, width, height, tmpdir: Path, ss: int = 3) -> np.ndarray:
    """Per pixel: index into `objects` of the surface seen at ss x ss sub-pixel positions
    (-1 = background), shape (H, W, ss*ss)."""
    import mitsuba as mi

    d = mitsuba_scene_dict(objects, mats, tmpdir, width, height, 1)
    # Mitsuba merges meshes that share an identical BSDF (all the white ones): give each its
    # own reflectance here so every object stays a shape with its own id.
    for i, o in enumerate(objects):
        d[o["name"]]["bsdf"]["reflectance"]["value"] = [0.01 * (i + 1)] * 3
    scene = mi.load_dict(d)
    sensor = scene.sensors()[0]
    index = {o["name"]: i for i, o in enumerate(objects)}  # shapes carry their dict key as id
    ids = np.full((height, width, ss * ss), -1, dtype=np.int32)
    offs = (np.arange(ss) + 0.5) / ss
    for y in range(height):
        for x in range(width):
            k = 0
            for oy in offs:
                for ox in offs:
                    ray, _ = sensor.sample_ray(0.0, 0.5, mi.ScalarPoint2f((x + ox) / width, (y + oy) / height),
                                               mi.ScalarPoint2f(0.5, 0.5))
                    si = scene.ray_intersect(ray)
                    if si.is_valid():
                        ids[y, x, k] = index.get(si.shape.id(), -2)
                    k += 1
    return ids


# --------------------------------------------------------------------------------------
# Images
# --------------------------------------------------------------------------------------
def read_exr(path: Path) -> np.ndarray:
    import mitsuba as mi

    bmp = mi.Bitmap(str(path))
    a = np.array(bmp, dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None].repeat(3, 2)
    return a[:, :, :3]


def write_png(path: Path, rgb_linear: np.ndarray) -> None:
    """Linear radiance -> sRGB PNG with a fixed exposure (no tone mapping beyond clamp)."""
    import mitsuba as mi

    a = np.clip(rgb_linear, 0.0, 1.0)
    s = np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1 / 2.4) - 0.055)
    mi.Bitmap(np.ascontiguousarray((s * 255 + 0.5).astype(np.uint8))).write(str(path))


def heat_png(path: Path, rel: np.ndarray, block: int, vmax: float, mask: np.ndarray | None = None) -> None:
    """Signed relative difference per block -> blue (shrad darker) / white / red (brighter),
    saturating at +-vmax. Masked-out blocks are grey."""
    import mitsuba as mi

    t = np.clip(rel / vmax, -1.0, 1.0)
    rgb = np.ones(rel.shape + (3,))
    pos, neg = np.clip(t, 0, 1), np.clip(-t, 0, 1)
    rgb[..., 1] -= pos + neg
    rgb[..., 2] -= pos
    rgb[..., 0] -= neg
    rgb = np.clip(rgb, 0, 1)
    if mask is not None:
        rgb[~mask] = 0.35
    big = np.repeat(np.repeat(rgb, block, 0), block, 1)
    # colour bar along the bottom: -vmax ... +vmax
    bar_h = max(8, block)
    ramp = np.linspace(-1, 1, big.shape[1])
    bar = np.ones((bar_h, big.shape[1], 3))
    bar[..., 1] -= np.abs(ramp)
    bar[..., 2] -= np.clip(ramp, 0, 1)
    bar[..., 0] -= np.clip(-ramp, 0, 1)
    out = np.concatenate([big, np.zeros((2, big.shape[1], 3)), np.clip(bar, 0, 1)], 0)
    mi.Bitmap(np.ascontiguousarray((out * 255 + 0.5).astype(np.uint8))).write(str(path))


def blocks(img: np.ndarray, b: int) -> np.ndarray:
    h, w, c = img.shape
    return img[: h - h % b, : w - w % b].reshape(h // b, b, w // b, b, c).mean(axis=(1, 3))


def rel_rmse(a: np.ndarray, ref: np.ndarray, mask: np.ndarray | None = None) -> float:
    """sqrt(sum |a - ref|^2 / sum |ref|^2) over the (masked) blocks and RGB."""
    if mask is not None:
        a, ref = a[mask], ref[mask]
    den = float(np.sum(ref**2))
    return float(np.sqrt(np.sum((a - ref) ** 2) / den)) if den > 0 else float("nan")


def region_masks(ids: np.ndarray, objects: list[dict], b: int) -> dict[str, np.ndarray]:
    """Block masks. A block's samples are the sub-pixel object ids of its pixels plus a
    one-pixel margin around it (so a sliver of an edge thinner than the id sampling, e.g. the
    0.07 px of the light in pixel row 31, still marks the block). A block belongs to a region
    when all its samples see that region ('pure'); 'edges' blocks see more than one object.
    Blocks that see any of the light are left out of everything but the
    first line (the light is L_e in both images, 50x brighter than the walls, and its
    anti-aliased edge would dominate the figure)."""
    names = [o["name"] for o in objects]
    h, w, s = ids.shape
    pad = np.pad(ids, ((1, 1), (1, 1), (0, 0)), mode="edge")
    nb_y, nb_x = h // b, w // b
    bid = np.empty((nb_y, nb_x, (b + 2) * (b + 2) * s), dtype=ids.dtype)
    for i in range(nb_y):
        for j in range(nb_x):
            bid[i, j] = pad[i * b : (i + 1) * b + 2, j * b : (j + 1) * b + 2].reshape(-1)
    li = names.index("light") if "light" in names else -99
    has_light = (bid == li).any(-1)
    has_bg = (bid < 0).any(-1)
    single = (bid == bid[..., :1]).all(-1)
    wall_idx = [names.index(n) for n in WALLS if n in names]
    block_idx = [names.index(n) for n in BLOCKS if n in names]
    in_walls = np.isin(bid, wall_idx).all(-1)
    in_blocks = np.isin(bid, block_idx).all(-1)
    base = ~has_light
    masks = {
        "all blocks (incl. light)": np.ones(has_light.shape, bool),
        "all but light": base,
        "walls (pure)": base & single & in_walls,
        "boxes (pure)": base & single & in_blocks,
        "edges (mixed)": base & ~single,
    }
    for n in WALLS + BLOCKS:
        if n in names:
            masks[f"  {n} (pure)"] = base & single & (bid[..., 0] == names.index(n))
    masks["light edge (light + other)"] = has_light & ~single
    return masks


# --------------------------------------------------------------------------------------
# shrad
# --------------------------------------------------------------------------------------
def render_shrad(exe: Path, out_dir: Path, tag: str, width: int, height: int, spp: int, patches: int,
                 shading: str, extra: list[str]) -> tuple[np.ndarray, float]:
    png = out_dir / f"shrad_{tag}.png"
    exr = out_dir / f"shrad_{tag}.exr"
    cmd = [str(exe), "render", "cornell", "-o", str(png), "--hdr", str(exr), "--width", str(width),
           "--height", str(height), "--spp", str(spp), "--patches", str(patches), "--shading", shading,
           "--quiet", *extra]
    t0 = time.time()
    subprocess.run(cmd, check=True)
    return read_exr(exr), time.time() - t0


def cpu_model() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shrad", default=str(ROOT / "target/release/shrad"), help="shrad executable")
    ap.add_argument("--obj", default=str(ROOT / "scenes/cornell.obj"))
    ap.add_argument("--size", type=int, default=256, help="image width = height")
    ap.add_argument("--spp", type=int, default=1024, help="Mitsuba samples per pixel (split in 2 seeds)")
    ap.add_argument("--block", type=int, default=8, help="block size (pixels) for the comparison")
    ap.add_argument("--runs", default="smooth:5000:64,flat:5000:64,smooth:20000:64,flat:20000:64,smooth:20000:16,smooth:20000:256",
                    help="shrad runs to compare, comma-separated SHADING:PATCHES:SPP")
    ap.add_argument("--shrad-arg", action="append", default=[], help="extra argument passed to shrad render")
    ap.add_argument("--out", default=str(ROOT / "docs/validation"), help="figure directory")
    ap.add_argument("--work", default=str(ROOT / "validation/out"), help="EXRs and cached reference")
    ap.add_argument("--reuse-reference", action="store_true", help="reuse a cached Mitsuba reference of the same settings")
    ap.add_argument("--threshold", type=float, default=0.03)
    args = ap.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    out_dir, work = Path(args.out), Path(args.work)
    out_dir.mkdir(parents=True, exist_ok=True)
    work.mkdir(parents=True, exist_ok=True)
    W = H = args.size
    b = args.block

    obj = Path(args.obj)
    objects = read_obj(obj)
    mats = read_mtl(obj.with_suffix(".mtl"))
    print(f"scene: {obj} ({len(objects)} objects: {', '.join(o['name'] for o in objects)})")
    for n in check_orientation(objects):
        print("  " + n)

    # ---- Mitsuba reference: two independent halves (noise estimate from their difference)
    key = f"ref_{W}x{H}_spp{args.spp}_v{mi.__version__}"
    ref_npz = work / f"{key}.npz"
    with tempfile.TemporaryDirectory() as td:
        tdp = Path(td)
        if args.reuse_reference and ref_npz.exists():
            z = np.load(ref_npz)
            half_a, half_b, mi_time = z["a"], z["b"], float(z["time"])
            print(f"mitsuba: reusing {ref_npz}")
        else:
            half = max(1, args.spp // 2)
            half_a, ta = render_mitsuba(objects, mats, W, H, half, 1, tdp)
            print(f"mitsuba {mi.__version__} scalar_rgb: {W}x{H} {half} spp (seed 1) in {ta:.1f} s", flush=True)
            half_b, tb = render_mitsuba(objects, mats, W, H, half, 2, tdp)
            print(f"mitsuba: {W}x{H} {half} spp (seed 2) in {tb:.1f} s", flush=True)
            mi_time = ta + tb
            np.savez_compressed(ref_npz, a=half_a, b=half_b, time=mi_time)
        ids_npy = work / f"ids_{W}x{H}.npy"
        if ids_npy.exists() and args.reuse_reference:
            ids = np.load(ids_npy)
        else:
            t0 = time.time()
            ids = object_ids(objects, mats, W, H, tdp)
            np.save(ids_npy, ids)
            print(f"object ids (3x3 rays per pixel) in {time.time() - t0:.1f} s")
    ref = 0.5 * (half_a + half_b)
    mi.Bitmap(ref.astype(np.float32)).write(str(work / "mitsuba.exr"))
    write_png(out_dir / "mitsuba.png", ref)

    masks = region_masks(ids, objects, b)
    ref_b = blocks(ref, b)
    # Noise of the mean of the two halves: rms(a - b) / 2 relative to the reference.
    noise = {name: 0.5 * rel_rmse(blocks(half_a, b), blocks(half_b, b), m) for name, m in masks.items()}
    print(f"\nblock size {b}x{b} px; Mitsuba noise (rel. RMSE of the reference, from its 2 halves): "
          f"all but light {100 * noise['all but light']:.2f} %, walls {100 * noise['walls (pure)']:.2f} %, "
          f"edges {100 * noise['edges (mixed)']:.2f} %")
    print("blocks per region: " + ", ".join(f"{k.strip()} {int(m.sum())}" for k, m in masks.items()))

    # ---- shrad runs
    results = []
    extra = list(args.shrad_arg)
    for run in args.runs.split(","):
        shading, patches, spp = run.split(":")
        patches, spp = int(patches), int(spp)
        tag = f"{shading}_{patches}_spp{spp}"
        if True:
            img, dt = render_shrad(Path(args.shrad), work, tag, W, H, spp, patches, shading, extra)
            img_b = blocks(img, b)
            row = {"tag": tag, "patches": patches, "shading": shading, "spp": spp, "time_s": dt}
            row["rmse"] = {name: rel_rmse(img_b, ref_b, m) for name, m in masks.items()}
            base = masks["all but light"]
            row["mean_ratio"] = (img_b[base].mean(0) / ref_b[base].mean(0)).tolist()
            results.append(row)
            print(f"shrad {tag}: {dt:.1f} s", flush=True)
            write_png(out_dir / f"shrad_{tag}.png", img)
            lum_w = np.array([0.2126, 0.7152, 0.0722])
            rel = (img_b @ lum_w) / np.maximum(ref_b @ lum_w, 1e-12) - 1.0
            heat_png(out_dir / f"diff_{tag}.png", rel, b, 0.10, mask=base)

    # ---- table
    names = list(masks)
    print(f"\nblock-averaged relative RMSE (block {b}x{b}, RGB; reference: Mitsuba {args.spp} spp)")
    hdr = f"{'region':28s} {'blocks':>6s} {'mi noise':>8s} " + " ".join(f"{r['tag']:>19s}" for r in results)
    print(hdr)
    print("-" * len(hdr))
    for n in names:
        print(f"{n:28s} {int(masks[n].sum()):6d} {100 * noise[n]:7.2f}% "
              + " ".join(f"{100 * r['rmse'][n]:18.2f}%" for r in results))
    print(f"{'mean ratio shrad/mitsuba R,G,B':28s} {'':6s} {'':8s} "
          + " ".join(f"{r['mean_ratio'][0]:.3f},{r['mean_ratio'][1]:.3f},{r['mean_ratio'][2]:.3f}".rjust(13)
                     for r in results))
    print(f"{'shrad time (s)':28s} {'':6s} {'':8s} " + " ".join(f"{r['time_s']:19.1f}" for r in results))

    summary = {
        "machine": {"cpu": cpu_model(), "cores": os.cpu_count(), "python": platform.python_version()},
        "mitsuba": {"version": mi.__version__, "variant": "scalar_rgb", "spp": args.spp, "size": [W, H],
                    "time_s": mi_time, "integrator": "path max_depth 64 rr_depth 64"},
        "block": b,
        "noise": noise,
        "blocks_per_region": {k: int(m.sum()) for k, m in masks.items()},
        "shrad": results,
    }
    (out_dir / "results.json").write_text(json.dumps(summary, indent=2))
    print(f"\nfigures and results.json in {out_dir}")
    worst = max(r["rmse"]["all but light"] for r in results)
    print(f"worst 'all but light' relative RMSE {100 * worst:.2f} % (target {100 * args.threshold:.0f} %): "
          + ("PASS" if worst <= args.threshold else "ABOVE TARGET"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
