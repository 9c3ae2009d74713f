#!/usr/bin/env python3
"""HDR-FLIP (NVIDIA's `flip-evaluator`) of shrad's dispersive solver against its reference
on the same patches, both converged: the per-pixel check of issue 22 (docs/results.md §14).

    target/py-venv/bin/python validation/flip_scene.py SCENE PATCHES [SIZE SPP] [key=value ...]

SCENE is a built-in scene name or a file; key=value are dispersive settings (`shrad
options`). Prints the mean and the 99th percentile of the error map, and each solve's time.
Needs the suite's venv (`scripts/setup-python`: shrad, numpy, flip-evaluator).
"""
import sys
import time

import flip_evaluator as flip
import numpy as np
import shrad


def value(v):
    if v in ("true", "false"):
        return v == "true"
    return float(v) if "." in v else int(v)


def main():
    scene, patches = sys.argv[1], int(sys.argv[2])
    rest = sys.argv[3:]
    numbers = [a for a in rest if "=" not in a]
    size, spp = (int(numbers[0]), int(numbers[1])) if len(numbers) == 2 else (512, 4)
    settings = {k: value(v) for k, v in (a.split("=", 1) for a in rest if "=" in a)}

    def picture(solver, **kw):
        t = time.time()
        e = shrad.Engine(shrad.load(scene, patches=patches), solver=solver, **kw)
        e.converge(8)
        img = np.asarray(e.render(size, size, spp=spp), np.float32)
        return np.ascontiguousarray(np.maximum(img, 0.0)), time.time() - t

    ref, t_ref = picture("reference")
    test, t_test = picture("dispersive", **settings)
    error_map, mean, _ = flip.evaluate(ref, test, "HDR", applyMagma=False)
    p99 = np.percentile(np.asarray(error_map), 99)
    print(f"{scene} at {patches} patches, {size}^2, {spp} spp: HDR-FLIP mean {mean:.4f}, "
          f"99th percentile {p99:.3f} (reference {t_ref:.0f} s, dispersive {t_test:.0f} s)")


if __name__ == "__main__":
    main()
