"""Same emitter-1mm-in-front-of-wall test, varying the corridor length L (scene extent) and the gap."""
import subprocess, csv, numpy as np
from lib import *
from scenes import room
for L in (2.0, 4.0, 10.0, 20.0):
    for gap in (0.0003, 0.001, 0.002, 0.003):
        sc = Scene("g"); room(sc, -0.5, 0.5, 1.0, 0, L, {}, floor_rho=(0.7, 0.7, 0.7))
        V, F = quad((-0.3, 0.2, gap), (0.3, 0.2, gap), (0.3, 0.8, gap), (-0.3, 0.8, gap))
        sc.mesh("panel", V, F, (0, 0, 0), emit=(1, 1, 1), strength=20.0, role="light")
        path = f"{OUT}/gap2_L{L:g}_g{gap}.gltf"; sc.write_gltf(path)
        csvp = path.replace(".gltf", ".csv")
        r = subprocess.run(["nice", "-n", "19", SHRAD, "render", path, "--patches", "5000", "--width", "32", "--height", "32",
                            "-o", f"{OUT}/gap_tmp.png", "--export-patches", csvp], capture_output=True, text=True)
        en = [l for l in (r.stdout + r.stderr).splitlines() if l.startswith("energy")][0]
        rows = [x for x in csv.DictReader(open(csvp)) if x["object"] == "wall_zneg"]
        c = np.array([[float(x["cx"]), float(x["cy"])] for x in rows]); B = np.array([float(x["r"]) for x in rows])
        ins = (abs(c[:, 0]) < 0.28) & (c[:, 1] > 0.22) & (c[:, 1] < 0.78)
        print(f"L {L:4g} m gap {gap*1000:4.1f} mm: wall behind panel B={B[ins].mean():.3f} elsewhere {B[~ins].mean():.3f} | {en.split('(')[1].split(')')[0]}", flush=True)
