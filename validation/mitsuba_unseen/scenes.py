import math, sys, json, time, os
import numpy as np
from lib import *

GREY = (0.7, 0.7, 0.7)


def room(sc, x0, x1, y1, z0, z1, floor_regions, colors=None, wall_regions=(), floor_rho=(0.6, 0.6, 0.6),
         skip=()):
    colors = colors or {}
    for n, (V, F) in room_walls(x0, x1, 0, y1, z0, z1).items():
        if n == "floor" or n in skip:
            continue
        sc.mesh(n, V, F, colors.get(n, GREY), region=(n in wall_regions), role="boundary")
    for n, (V, F) in floor_tiles(x0, x1, z0, z1, 0.0, floor_regions).items():
        nm = "floor_rest" if n == "_rest" else n
        sc.mesh(nm, V, F, floor_rho, region=(n != "_rest"), role="boundary")


def s_lights():
    """(a) 4x3x4 room, red wall at x=-2, lit only by a point light and a spot light."""
    sc = Scene("lights")
    room(sc, -2, 2, 3, -2, 2,
         {"floor_by_red": (-2, -1.5, -1, 1), "floor_mid": (-0.5, 0.5, -0.5, 0.5),
          "floor_spot": (0.8, 1.2, -1.2, -0.8), "floor_by_white": (1.5, 2, -1, 1)},
         colors={"wall_xneg": (0.8, 0.1, 0.1)}, wall_regions=("ceiling", "wall_xneg", "wall_zneg"))
    sc.lights.append(dict(kind="point", pos=(-0.6, 2.2, 0.6), I=5.0, color=(1, 1, 1)))
    sc.lights.append(dict(kind="spot", pos=(1.0, 2.8, -1.0), dir=(0, -1, 0), I=20.0, inner=19, outer=20,
                          color=(1.0, 0.9, 0.7)))
    sc.camera = ((0, 1.5, 1.95), (0, 0.8, 0), 70)
    return sc


def s_contact():
    """(b) cube resting on the floor + 0.8 m plate floating 1 cm above; ceiling panel light."""
    sc = Scene("contact")
    room(sc, -2, 2, 3, -2, 2,
         {"floor_under_plate": (0.5, 1.3, -0.4, 0.4),
          "floor_ring_cube": [(-1.2, -0.4, -0.4, -0.3), (-1.2, -0.4, 0.3, 0.4), (-1.2, -1.1, -0.3, 0.3), (-0.5, -0.4, -0.3, 0.3)],
          "floor_open": (-0.5, 0.5, 1.0, 1.8)}, wall_regions=("ceiling",))
    # ceiling light 1x1 facing down, 1 mm below ceiling
    V, F = quad((-0.5, 2.999, -0.5), (0.5, 2.999, -0.5), (0.5, 2.999, 0.5), (-0.5, 2.999, 0.5))
    sc.mesh("panel", V, F, (0, 0, 0), emit=(1, 1, 1), strength=10.0, role="light")
    for n, (V, F) in box_faces((-1.1, 0, -0.3), (-0.5, 0.6, 0.3)):
        sc.mesh("cube_" + n, V, F, (0.5, 0.5, 0.5), region=(n in ("left", "top")), role="interior")
    g = float(os.environ.get("GAP", "0.01"))
    if g != 0.01:
        sc.name = f"contact_gap{g}"
    for n, (V, F) in box_faces((0.5, g, -0.4), (1.3, g + 0.02, 0.4)):
        sc.mesh("plate_" + n, V, F, (0.5, 0.5, 0.5), region=(n in ("bottom", "top")), role="interior")
    sc.camera = ((0, 1.6, 1.95), (0, 0.2, 0), 70)
    return sc


def s_corridor():
    """(c) 1 x 1 x 10 corridor, light panel on the end wall z=0."""
    sc = Scene("corridor")
    regs = {f"floor_z{a}": (-0.5, 0.5, a - 0.5, a + 0.5) for a in (1, 3, 5, 7, 9)}
    room(sc, -0.5, 0.5, 1.0, 0, 10, regs, wall_regions=("wall_zpos",), floor_rho=(0.7, 0.7, 0.7))
    g = float(os.environ.get("CGAP", "0.001"))
    if g != 0.001:
        sc.name = f"corridor_gap{g}"
    V, F = quad((-0.3, 0.2, g), (0.3, 0.2, g), (0.3, 0.8, g), (-0.3, 0.8, g))
    sc.mesh("panel", V, F, (0, 0, 0), emit=(1, 1, 1), strength=20.0, role="light")
    sc.camera = ((0, 0.6, 0.3), (0, 0.4, 10), 50)
    return sc


def s_hier():
    """(d) parent scaled (2,1,0.5) rotated 30 deg about Y, child rotated 45 about Z, mirrored (-1,1,1)."""
    sc = Scene("hier")
    room(sc, -2, 2, 3, -2, 2, {"floor_below": (-0.6, 0.6, -0.6, 0.6)}, wall_regions=())
    sc.lights.append(dict(kind="point", pos=(0.3, 2.5, 0.9), I=6.0))
    p = sc.add_node("parent", None, T_=(0, 0.7, 0), R_=R((0, 1, 0), 30), S_=(2, 1, 0.5))
    prims = []
    for n, (V, F) in box_faces((-0.2, -0.2, -0.2), (0.2, 0.2, 0.2)):
        prims.append((V, F, dict(rho=(0.3, 0.6, 0.8), emit=(0, 0, 0), strength=1.0, two=False, region=True)))
    sc.add_node("child", p, T_=(0.1, 0, 0.2), R_=R((0, 0, 1), 45), S_=(-1, 1, 1), prims=prims, role="interior")
    sc.camera = ((0, 1.8, 1.95), (0, 0.5, 0), 65)
    return sc


def s_emissive():
    """(e) no lights: a doubleSided emissive panel standing in the middle (black reflectance),
    an emissive+reflective box on the floor; KHR_materials_emissive_strength."""
    sc = Scene("emissive")
    room(sc, -2, 2, 3, -2, 2, {"floor_xneg": (-1.5, -0.5, -0.5, 0.5), "floor_xpos": (0.5, 1.5, -0.5, 0.5)},
         wall_regions=("ceiling", "wall_xneg", "wall_xpos"))
    # vertical panel in the plane x=0, front faces +x, 1 m wide (z), 1 m tall
    V, F = quad((0, 0.5, 0.5), (0, 0.5, -0.5), (0, 1.5, -0.5), (0, 1.5, 0.5))
    sc.mesh("panel2s", V, F, (0, 0, 0), emit=(1.0, 0.6, 0.3), strength=8.0, two=True, role="light")
    for n, (V, F) in box_faces((-0.3, 0, 1.2), (0.3, 0.4, 1.8)):
        sc.mesh("ebox_" + n, V, F, (0.5, 0.5, 0.5), emit=(0.2, 0.4, 1.0), strength=3.0, region=(n == "top"))
    sc.camera = ((0, 1.5, -1.95), (0, 0.8, 0), 70)
    return sc


def s_sun():
    """(f) sun through a 1.2 x 1.0 window in the x=+2 wall of a closed room."""
    sc = Scene("sun")
    x0, x1, y1, z0, z1 = -2, 2, 3, -2, 2
    walls = room_walls(x0, x1, 0, y1, z0, z1)
    for n in ("ceiling", "wall_xneg", "wall_zneg", "wall_zpos"):
        V, F = walls[n]
        sc.mesh(n, V, F, GREY, region=n in ("ceiling", "wall_xneg"), role="boundary")
    # wall x=+2 facing -x, with hole y in [1,2], z in [-0.6,0.6]
    def wq(za, zb, ya, yb):
        return quad((2, ya, za), (2, ya, zb), (2, yb, zb), (2, yb, za))
    parts = [wq(-2, 2, 0, 1), wq(-2, 2, 2, 3), wq(-2, -0.6, 1, 2), wq(0.6, 2, 1, 2)]
    V, F = merge(parts)
    sc.mesh("wall_xpos", V, F, GREY, role="boundary")
    for n, (V, F) in floor_tiles(x0, x1, z0, z1, 0.0, {"floor_sunlit_area": (-0.5, 1.5, -1.2, 1.2),
                                                       "floor_far": (-2, -1, -2, 2)}).items():
        sc.mesh("floor_rest" if n == "_rest" else n, V, F, (0.6, 0.6, 0.6), region=(n != "_rest"), role="boundary")
    sc.lights.append(dict(kind="directional", dir=(-1.0, -0.8, 0.25), E=3.0))
    sc.camera = ((-1.95, 1.6, 1.95), (0.5, 0.5, -0.5), 70)
    return sc


SCENES = dict(lights=s_lights, contact=s_contact, corridor=s_corridor, hier=s_hier, emissive=s_emissive, sun=s_sun)

def s_rug():
    """a 1 x 1 m rug (single quad, up) RUGGAP above the floor of a 10 x 3 x 10 room, point light above-side."""
    g = float(os.environ.get("RUGGAP", "0.001"))
    sc = Scene(f"rug_gap{g}")
    room(sc, -5, 5, 3, -5, 5, {"floor_under_rug": (-0.5, 0.5, -0.5, 0.5),
                               "floor_ring": [(-0.6, 0.6, -0.6, -0.5), (-0.6, 0.6, 0.5, 0.6), (-0.6, -0.5, -0.5, 0.5), (0.5, 0.6, -0.5, 0.5)]})
    V, F = quad((-0.5, g, -0.5), (-0.5, g, 0.5), (0.5, g, 0.5), (0.5, g, -0.5))
    sc.mesh("rug", V, F, (0.3, 0.3, 0.3), region=True, role="interior")
    sc.lights.append(dict(kind="point", pos=(1.5, 2.5, 0.5), I=10.0))
    sc.camera = ((0, 2.5, 4.9), (0, 0, 0), 50)
    return sc




SCENES["rug"] = s_rug

if __name__ == "__main__":
    name = sys.argv[1]
    patches = [int(p) for p in sys.argv[2].split(",")]
    spp = int(sys.argv[3]) if len(sys.argv) > 3 else 20000
    do_mi = spp > 0
    sc = SCENES[name]()
    path = f"{OUT}/{name}.gltf"
    sc.write_gltf(path)
    print(f"== {name}: wrote {path}", flush=True)
    res = {"shrad": {}, "mitsuba": None}
    for p in patches:
        res["shrad"][p] = run_shrad(sc, path, p)
    if do_mi:
        res["mitsuba"] = run_mitsuba(sc, spp_meter=spp)
        json.dump(res, open(f"{OUT}/{name}_results.json", "w"), indent=1)
    else:
        prev = json.load(open(f"{OUT}/{name}_results.json")) if os.path.exists(f"{OUT}/{name}_results.json") else {"shrad": {}, "mitsuba": None}
        prev["shrad"].update({str(k): v for k, v in res["shrad"].items()})
        json.dump(prev, open(f"{OUT}/{name}_results.json", "w"), indent=1)
        res = prev
    m = res["mitsuba"]
    if m:
        print(f"{'region':22s} {'Mitsuba E (rgb)':34s} " + " ".join(f"p={p:<28}" for p in res["shrad"]))
        for nm, mv in m.items():
            line = f"{nm:22s} " + " ".join(f"{x:9.4f}" for x in mv["E"]) + f" (se {max(mv['mitsuba_pathE_se']):.4f}) "
            for p, sv in res["shrad"].items():
                if sv and nm in sv:
                    line += " ratio " + " ".join(f"{a/b:6.3f}" if b > 0 else "  nan " for a, b in zip(sv[nm]["E"], mv["E"]))
            print(line)
