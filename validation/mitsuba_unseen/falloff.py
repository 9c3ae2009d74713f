"""Open floor (nothing to bounce to): shrad's per-patch irradiance = direct light only; compare with
the KHR_lights_punctual formulas: spot t^2 falloff (inner 10, outer 40 deg), point with range 3 m."""
import subprocess, csv, math, numpy as np
from lib import *
sc = Scene("falloff")
V, F = quad((-10, 0, -10), (-10, 0, 10), (10, 0, 10), (10, 0, -10))
sc.mesh("floor", V, F, (0.5, 0.5, 0.5), role="boundary")
sc.lights.append(dict(kind="spot", pos=(-3, 2, 0), dir=(0, -1, 0), I=10.0, inner=10, outer=40))
sc.lights.append(dict(kind="point", pos=(4, 1, 0), I=3.0, range=3.0))
sc.write_gltf(f"{OUT}/falloff.gltf")
import json
g = json.load(open(f"{OUT}/falloff.gltf")); g["extensions"]["KHR_lights_punctual"]["lights"][1]["range"] = 3.0
json.dump(g, open(f"{OUT}/falloff.gltf", "w"))
subprocess.run(["nice", "-n", "19", SHRAD, "render", f"{OUT}/falloff.gltf", "--patches", "40000", "--width", "64", "--height", "64",
                "-o", f"{OUT}/falloff.png", "--export-patches", f"{OUT}/falloff.csv", "-q"], check=True)
rows = list(csv.DictReader(open(f"{OUT}/falloff.csv")))
c = np.array([[float(r["cx"]), float(r["cy"]), float(r["cz"])] for r in rows]); E = np.array([float(r["r"]) for r in rows]) / 0.5
def spot(p):
    d = np.array([-3, 2, 0]) - p; dist = np.linalg.norm(d); w = d / dist
    ca = w[1]; ci, co = math.cos(math.radians(10)), math.cos(math.radians(40))
    t = min(max((ca - co) / (ci - co), 0), 1); return 10 * t * t * w[1] / dist**2
def point(p):
    d = np.array([4, 1, 0]) - p; dist = np.linalg.norm(d); w = d / dist
    win = max(min(1 - (dist / 3) ** 4, 1), 0); return 3 * win * w[1] / dist**2
A = np.array([spot(p) + point(p) for p in c])
for lab, m in (("spot inner cone (r<0.3)", np.hypot(c[:, 0] + 3, c[:, 2]) < 0.3),
               ("spot ramp (0.5<r<1.5)", (np.hypot(c[:, 0] + 3, c[:, 2]) > 0.5) & (np.hypot(c[:, 0] + 3, c[:, 2]) < 1.5)),
               ("point near (r<1)", np.hypot(c[:, 0] - 4, c[:, 2]) < 1),
               ("point range window (1.5<r<2.7)", (np.hypot(c[:, 0] - 4, c[:, 2]) > 1.5) & (np.hypot(c[:, 0] - 4, c[:, 2]) < 2.7))):
    print(f"{lab:32s} n={m.sum():5d} sum shrad E / sum analytic = {E[m].sum()/A[m].sum():.4f}  per-patch ratio p5/p50/p95 = "
          + " ".join(f"{x:.3f}" for x in np.percentile(E[m] / np.maximum(A[m], 1e-12), [5, 50, 95])))
far = (np.hypot(c[:, 0] - 4, c[:, 2]) > 3.1) & (np.hypot(c[:, 0] + 3, c[:, 2]) > 2.0)
print("outside both (beyond range / cone): max shrad E", E[far].max())
