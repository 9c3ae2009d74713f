"""Scene builder: writes glTF (hand-made JSON, base64 buffer) for shrad and builds the
equivalent Mitsuba 3 scene from the SAME world-space triangles (computed here with numpy
from the glTF node matrices), with irradiancemeters on 'region' objects."""
import base64, json, math, struct, subprocess, csv, time, os
import numpy as np

_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHRAD = os.environ.get("SHRAD", os.path.join(_ROOT, "target", "release", "shrad"))
OUT = os.environ.get("OUT", os.path.join(_ROOT, "target", "mitsuba-unseen"))
os.makedirs(OUT, exist_ok=True)


def quad(c0, c1, c2, c3):
    """two triangles, CCW seen from front"""
    return [c0, c1, c2, c3], [[0, 1, 2], [0, 2, 3]]


def merge(parts):
    V, F = [], []
    for v, f in parts:
        o = len(V)
        V += [list(map(float, p)) for p in v]
        F += [[a + o, b + o, c + o] for a, b, c in f]
    return V, F


def box_faces(lo, hi):
    """6 quads of an axis-aligned box, normals outward; returns list of (name, (V,F))"""
    x0, y0, z0 = lo; x1, y1, z1 = hi
    return [
        ("top", quad((x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0))),
        ("bottom", quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1))),
        ("front", quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1))),   # +z
        ("back", quad((x1, y0, z0), (x0, y0, z0), (x0, y1, z0), (x1, y1, z0))),    # -z
        ("left", quad((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0))),    # -x
        ("right", quad((x1, y0, z1), (x1, y0, z0), (x1, y1, z0), (x1, y1, z1))),   # +x
    ]


def floor_tiles(x0, x1, z0, z1, y, regions, up=True):
    """Tile the rectangle [x0,x1]x[z0,z1] at height y (normal +y if up else -y). regions: dict
    name->(ax0,ax1,az0,az1) or list of such rects. Returns dict name->(V,F), rest under '_rest'."""
    xs, zs = {x0, x1}, {z0, z1}
    reg = {}
    for n, r in regions.items():
        rs = r if isinstance(r[0], (list, tuple)) else [r]
        reg[n] = rs
        for a in rs:
            xs |= {a[0], a[1]}; zs |= {a[2], a[3]}
    xs, zs = sorted(xs), sorted(zs)
    out = {}
    for i in range(len(xs) - 1):
        for j in range(len(zs) - 1):
            cx, cz = (xs[i] + xs[i + 1]) / 2, (zs[j] + zs[j + 1]) / 2
            if not (x0 < cx < x1 and z0 < cz < z1):
                continue
            owner = "_rest"
            for n, rs in reg.items():
                if any(a[0] < cx < a[1] and a[2] < cz < a[3] for a in rs):
                    owner = n
            a, b, c, d = xs[i], xs[i + 1], zs[j], zs[j + 1]
            if up:
                q = quad((a, y, c), (a, y, d), (b, y, d), (b, y, c))
            else:
                q = quad((a, y, c), (b, y, c), (b, y, d), (a, y, d))
            out.setdefault(owner, []).append(q)
    return {n: merge(p) for n, p in out.items()}


def room_walls(x0, x1, y0, y1, z0, z1):
    """inward-facing walls as quads (floor and ceiling separate)"""
    return {
        "ceiling": quad((x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)),
        "wall_xneg": quad((x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)),
        "wall_xpos": quad((x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0)),
        "wall_zneg": quad((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)),
        "wall_zpos": quad((x0, y0, z1), (x0, y1, z1), (x1, y1, z1), (x1, y0, z1)),
        "floor": quad((x0, y0, z0), (x0, y0, z1), (x1, y0, z1), (x1, y0, z0)),
    }


# ---------------------------------------------------------------- transforms
def T(t):
    m = np.eye(4); m[:3, 3] = t; return m


def S(s):
    return np.diag([s[0], s[1], s[2], 1.0])


def R(axis, deg):
    a = np.asarray(axis, float); a /= np.linalg.norm(a)
    th = math.radians(deg); c, s = math.cos(th), math.sin(th)
    x, y, z = a
    m = np.eye(4)
    m[:3, :3] = [[c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
                 [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
                 [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)]]
    return m


def quat_of(m3):
    m = np.asarray(m3, float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2; w = 0.25 * s
        x = (m[2, 1] - m[1, 2]) / s; y = (m[0, 2] - m[2, 0]) / s; z = (m[1, 0] - m[0, 1]) / s
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2; w = (m[2, 1] - m[1, 2]) / s
        x = 0.25 * s; y = (m[0, 1] + m[1, 0]) / s; z = (m[0, 2] + m[2, 0]) / s
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2; w = (m[0, 2] - m[2, 0]) / s
        x = (m[0, 1] + m[1, 0]) / s; y = 0.25 * s; z = (m[1, 2] + m[2, 1]) / s
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2; w = (m[1, 0] - m[0, 1]) / s
        x = (m[0, 2] + m[2, 0]) / s; y = (m[1, 2] + m[2, 1]) / s; z = 0.25 * s
    q = np.array([x, y, z, w]); return list(q / np.linalg.norm(q))


def look_rot(d, up=(0, 1, 0)):
    """rotation matrix whose -Z is d"""
    d = np.asarray(d, float); d /= np.linalg.norm(d)
    zc = -d
    upv = np.asarray(up, float)
    if abs(np.dot(upv, zc)) > 0.99:
        upv = np.array([0, 0, 1.0])
    xc = np.cross(upv, zc); xc /= np.linalg.norm(xc)
    yc = np.cross(zc, xc)
    return np.stack([xc, yc, zc], 1)


# ---------------------------------------------------------------- scene
class Scene:
    def __init__(self, name):
        self.name = name
        self.nodes = []      # dict(name, parent, trs or matrix, mesh=[prims], extras)
        self.objects = []    # for mitsuba: dict(name, V_world, F, rho, emit, two, region)
        self.lights = []     # dict(kind, pos, dir, I (W/sr) or E (W/m2), color, inner, outer)
        self.camera = None

    def add_node(self, name, parent=None, T_=None, R_=None, S_=None, prims=None, role=None):
        """prims: list of (V,F,mat) where mat=dict(rho, emit=(0,0,0), strength=1, two=False,
        region=bool). Returns node index."""
        n = dict(name=name, parent=parent, t=T_, r=R_, s=S_, prims=prims, role=role)
        self.nodes.append(n)
        return len(self.nodes) - 1

    def local(self, i):
        n = self.nodes[i]
        m = np.eye(4)
        if n["t"] is not None: m = m @ T(n["t"])
        if n["r"] is not None: m = m @ n["r"]
        if n["s"] is not None: m = m @ S(n["s"])
        return m

    def world(self, i):
        m = self.local(i)
        p = self.nodes[i]["parent"]
        while p is not None:
            m = self.local(p) @ m
            p = self.nodes[p]["parent"]
        return m

    def mesh(self, name, V, F, rho, emit=(0, 0, 0), strength=1.0, two=False, region=False,
             role=None, parent=None, T_=None, R_=None, S_=None):
        return self.add_node(name, parent, T_, R_, S_,
                             [(V, F, dict(rho=rho, emit=emit, strength=strength, two=two, region=region))],
                             role)

    # ---- glTF
    def write_gltf(self, path):
        buf = bytearray(); bviews = []; accs = []; meshes = []; mats = []; nodes = []
        def add_view(data, target):
            while len(buf) % 4: buf.append(0)
            off = len(buf); buf.extend(data)
            bviews.append(dict(buffer=0, byteOffset=off, byteLength=len(data), target=target))
            return len(bviews) - 1
        for ni, n in enumerate(self.nodes):
            node = dict(name=n["name"])
            if n["t"] is not None: node["translation"] = list(map(float, n["t"]))
            if n["r"] is not None: node["rotation"] = quat_of(n["r"][:3, :3])
            if n["s"] is not None: node["scale"] = list(map(float, n["s"]))
            if n["role"]: node["extras"] = {"shrad_role": n["role"]}
            if n["prims"]:
                prims = []
                for V, F, mat in n["prims"]:
                    v = np.asarray(V, np.float32); f = np.asarray(F, np.uint32)
                    bv = add_view(v.tobytes(), 34962)
                    accs.append(dict(bufferView=bv, componentType=5126, count=len(v), type="VEC3",
                                     min=v.min(0).tolist(), max=v.max(0).tolist()))
                    pa = len(accs) - 1
                    bi = add_view(f.tobytes(), 34963)
                    accs.append(dict(bufferView=bi, componentType=5125, count=f.size, type="SCALAR"))
                    ia = len(accs) - 1
                    m = dict(pbrMetallicRoughness=dict(baseColorFactor=list(mat["rho"]) + [1.0],
                                                       metallicFactor=0.0, roughnessFactor=1.0),
                             doubleSided=bool(mat["two"]))
                    if any(mat["emit"]):
                        m["emissiveFactor"] = list(mat["emit"])
                        if mat["strength"] != 1.0:
                            m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": mat["strength"]}}
                    mats.append(m)
                    prims.append(dict(attributes={"POSITION": pa}, indices=ia, material=len(mats) - 1))
                meshes.append(dict(name=n["name"], primitives=prims))
                node["mesh"] = len(meshes) - 1
            nodes.append(node)
        children = {}
        for i, n in enumerate(self.nodes):
            if n["parent"] is not None:
                children.setdefault(n["parent"], []).append(i)
        for p, c in children.items():
            nodes[p]["children"] = c
        roots = [i for i, n in enumerate(self.nodes) if n["parent"] is None]
        ext_used = set()
        lights = []
        for li, L in enumerate(self.lights):
            d = dict(type=L["kind"], color=list(L.get("color", (1, 1, 1))))
            if L["kind"] == "directional":
                d["intensity"] = L["E"] * 683.0
            else:
                d["intensity"] = L["I"] * 683.0
            if L["kind"] == "spot":
                d["spot"] = dict(innerConeAngle=math.radians(L["inner"]), outerConeAngle=math.radians(L["outer"]))
            lights.append(d)
            node = dict(name=f"light{li}", extensions={"KHR_lights_punctual": {"light": li}})
            if L["kind"] != "point":
                node["rotation"] = quat_of(look_rot(L["dir"]))
            if L["kind"] != "directional":
                node["translation"] = list(map(float, L["pos"]))
            nodes.append(node); roots.append(len(nodes) - 1)
            ext_used.add("KHR_lights_punctual")
        cams = []
        if self.camera:
            eye, tgt, fov = self.camera
            cams.append(dict(type="perspective", perspective=dict(yfov=math.radians(fov), aspectRatio=1.0, znear=0.01)))
            nodes.append(dict(name="cam", camera=0, translation=list(eye),
                              rotation=quat_of(look_rot(np.subtract(tgt, eye)))))
            roots.append(len(nodes) - 1)
        if any("extensions" in m for m in mats):
            ext_used.add("KHR_materials_emissive_strength")
        g = dict(asset=dict(version="2.0", generator="mipass"), scene=0, scenes=[dict(nodes=roots)],
                 nodes=nodes, meshes=meshes, materials=mats, accessors=accs, bufferViews=bviews,
                 buffers=[dict(byteLength=len(buf), uri="data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode())])
        if cams: g["cameras"] = cams
        if lights: g["extensions"] = {"KHR_lights_punctual": {"lights": lights}}
        if ext_used: g["extensionsUsed"] = sorted(ext_used)
        with open(path, "w") as fh:
            json.dump(g, fh)

    # ---- world objects
    def world_objects(self):
        objs = []
        for i, n in enumerate(self.nodes):
            if not n["prims"]:
                continue
            M = self.world(i)
            mirror = np.linalg.det(M[:3, :3]) < 0
            for k, (V, F, mat) in enumerate(n["prims"]):
                v = np.asarray(V, float)
                vw = (M @ np.c_[v, np.ones(len(v))].T).T[:, :3]
                f = np.asarray(F, int)
                if mirror:   # world normal = inverse-transpose: winding flips in world space
                    f = f[:, ::-1]
                nm = n["name"] if len(n["prims"]) == 1 else f"{n['name']}.{k}"
                objs.append(dict(name=nm, V=vw, F=f, **mat))
        return objs

    # ---- mitsuba
    def mitsuba_dict(self, spp_img=64, res=128, max_depth=100):
        import mitsuba as mi
        Tm = mi.ScalarTransform4f
        d = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth, "hide_emitters": False}}
        os.makedirs(f"{OUT}/{self.name}_mi", exist_ok=True)
        self.meter_names = []
        for o in self.world_objects():
            for side in ([1, -1] if (o["two"] and any(o["emit"])) else [1]):
                fn = f"{OUT}/{self.name}_mi/{o['name']}_{side}.obj"
                V = o["V"].copy(); F = o["F"] if side == 1 else o["F"][:, ::-1]
                if side == -1:  # offset the back emitter slightly along its normal
                    n = np.cross(V[F[0][1]] - V[F[0][0]], V[F[0][2]] - V[F[0][0]]); n /= np.linalg.norm(n)
                    V = V + 1e-4 * n
                with open(fn, "w") as fh:
                    fh.write("".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in V))
                    fh.write("".join(f"f {a+1} {b+1} {c+1}\n" for a, b, c in F))
                rho = o["rho"]
                bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rho)}}
                if o["two"] and not any(o["emit"]):
                    bsdf = {"type": "twosided", "bsdf": bsdf}
                sd = {"type": "obj", "filename": fn, "face_normals": True, "bsdf": bsdf}
                if any(o["emit"]):
                    sd["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": [e * o["strength"] for e in o["emit"]]}}
                if o["region"] and side == 1:
                    sd["sensor"] = {"type": "irradiancemeter", "id": "meter_" + o["name"], "film": {"type": "hdrfilm", "width": 1, "height": 1,
                                    "rfilter": {"type": "box"}, "pixel_format": "rgb", "component_format": "float32"},
                                    "sampler": {"type": "independent", "sample_count": 1, "seed": 7 + len(self.meter_names)}}
                    self.meter_names.append(o["name"])
                d[f"{o['name']}_{side}".replace(".", "__")] = sd
        for li, L in enumerate(self.lights):
            rgb = lambda s: {"type": "rgb", "value": [s * c for c in L.get("color", (1, 1, 1))]}
            if L["kind"] == "point":
                d[f"L{li}"] = {"type": "point", "position": list(L["pos"]), "intensity": rgb(L["I"])}
            elif L["kind"] == "spot":
                tgt = np.add(L["pos"], L["dir"])
                d[f"L{li}"] = {"type": "spot", "to_world": Tm().look_at(origin=list(L["pos"]), target=tgt.tolist(), up=[0, 0, 1] if abs(L["dir"][1]) < .9 else [1, 0, 0]),
                               "intensity": rgb(L["I"]), "cutoff_angle": L["outer"], "beam_width": L["inner"]}
            else:
                d[f"L{li}"] = {"type": "directional", "direction": list(L["dir"]), "irradiance": rgb(L["E"])}
        if self.camera:
            eye, tgt, fov = self.camera
            d["cam"] = {"type": "perspective", "fov": fov, "fov_axis": "y",
                        "to_world": Tm().look_at(origin=list(eye), target=list(tgt), up=[0, 1, 0]),
                        "sampler": {"type": "independent", "sample_count": spp_img},
                        "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"},
                                 "pixel_format": "rgb"}}
        return d


# ---------------------------------------------------------------- direct light from delta lights
def direct_delta(scene, mscene, obj, n_samples=4000, seed=1):
    """area-averaged direct irradiance of punctual lights on obj (world tris), glTF falloff,
    visibility via Mitsuba's ray tracer."""
    import mitsuba as mi
    rng = np.random.default_rng(seed)
    V, F = obj["V"], obj["F"]
    a = V[F[:, 0]]; b = V[F[:, 1]]; c = V[F[:, 2]]
    cr = np.cross(b - a, c - a); area = 0.5 * np.linalg.norm(cr, axis=1)
    nrm = cr / (2 * area[:, None])
    tri = rng.choice(len(F), n_samples, p=area / area.sum())
    u, v = rng.random(n_samples), rng.random(n_samples)
    flip = u + v > 1; u[flip] = 1 - u[flip]; v[flip] = 1 - v[flip]
    P = a[tri] + u[:, None] * (b - a)[tri] + v[:, None] * (c - a)[tri]
    N = nrm[tri]
    E = np.zeros(3)
    for L in scene.lights:
        col = np.asarray(L.get("color", (1, 1, 1)))
        tot = 0.0
        for p, n in zip(P, N):
            if L["kind"] == "directional":
                wi = -np.asarray(L["dir"], float); wi /= np.linalg.norm(wi)
                cos = np.dot(n, wi)
                if cos <= 0: continue
                ray = mi.Ray3f(mi.Point3f(*(p + 1e-4 * n)), mi.Vector3f(*wi))
                if mscene.ray_test(ray): continue
                tot += L["E"] * cos
            else:
                dv = np.asarray(L["pos"]) - p; dist = np.linalg.norm(dv); wi = dv / dist
                cos = np.dot(n, wi)
                if cos <= 0: continue
                f = 1.0
                if L["kind"] == "spot":
                    ax = np.asarray(L["dir"], float); ax /= np.linalg.norm(ax)
                    ca = np.dot(-wi, ax)
                    ci, co = math.cos(math.radians(L["inner"])), math.cos(math.radians(L["outer"]))
                    t = min(max((ca - co) / (ci - co), 0), 1); f = t * t
                    if f == 0: continue
                ray = mi.Ray3f(mi.Point3f(*(p + 1e-4 * n)), mi.Vector3f(*wi)); ray.maxt = dist * (1 - 1e-4) - 1e-4
                if mscene.ray_test(ray): continue
                tot += L["I"] * f * cos / dist ** 2
        E += col * tot / n_samples
    return E


def run_mitsuba(scene, spp_meter=20000, batches=4, img=True, spp_img=64, res=128):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    d = scene.mitsuba_dict(spp_img=spp_img, res=res)
    ms = mi.load_dict(d)
    sensors = ms.sensors()
    objs = {o["name"]: o for o in scene.world_objects()}
    res_ = {}
    # sensors order: meters in order of dict insertion? map by shape id
    for si, s in enumerate(sensors):
        sh = s.get_shape() if hasattr(s, "get_shape") else None
        if sh is None:
            continue
        nm = sh.id()[:-2].replace("__", ".")
        vals = []
        t0 = time.time()
        for b in range(batches):
            im = mi.render(ms, sensor=si, spp=spp_meter // batches, seed=1000 * b + si)
            vals.append(np.array(im).reshape(-1)[:3])
        vals = np.array(vals)
        ind = vals.mean(0); err = vals.std(0, ddof=1) / math.sqrt(batches)
        dd = direct_delta(scene, ms, objs[nm]) if scene.lights else np.zeros(3)
        res_[nm] = dict(mitsuba_pathE=ind.tolist(), mitsuba_pathE_se=err.tolist(), delta_direct=dd.tolist(),
                        E=(ind + dd).tolist(), secs=time.time() - t0)
        print(f"  mitsuba meter {nm}: path {ind} +- {err}, delta-direct {dd}  ({time.time()-t0:.0f}s)", flush=True)
    if img and scene.camera:
        ci = [i for i, s in enumerate(sensors) if s.get_shape() is None][0]
        t0 = time.time()
        im = mi.render(ms, sensor=ci, spp=spp_img)
        mi.Bitmap(im).write(f"{OUT}/{scene.name}_mitsuba.exr")
        print(f"  mitsuba image {time.time()-t0:.0f}s", flush=True)
    return res_


def run_shrad(scene, path, patches, res=128, extra=()):
    tag = f"{scene.name}_p{patches}"
    cmd = ["nice", "-n", "19", SHRAD, "render", path, "--solver", "reference", "--patches", str(patches),
           "--width", str(res), "--height", str(res), "--spp", "16", "-o", f"{OUT}/{tag}.png",
           "--hdr", f"{OUT}/{tag}.exr", "--export-patches", f"{OUT}/{tag}.csv", *extra]
    t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    log = p.stdout + p.stderr
    open(f"{OUT}/{tag}.log", "w").write(" ".join(cmd) + "\n" + log)
    if p.returncode != 0:
        print("SHRAD FAILED", p.returncode, log); return None
    rows = list(csv.DictReader(open(f"{OUT}/{tag}.csv")))
    objs = {o["name"]: o for o in scene.world_objects()}
    out = {}
    for nm, o in objs.items():
        rr = [r for r in rows if r["object"] == nm]
        if not rr:
            continue
        A = np.array([float(r["area"]) for r in rr])
        B = np.array([[float(r["r"]), float(r["g"]), float(r["b"])] for r in rr])
        M = np.asarray(o["emit"], float) * o["strength"] * math.pi
        rho = np.asarray(o["rho"], float)
        Bm = (A[:, None] * B).sum(0) / A.sum()
        with np.errstate(divide="ignore", invalid="ignore"):
            E = np.where(rho > 0, (Bm - M) / rho, np.nan)
        out[nm] = dict(B=Bm.tolist(), E=E.tolist(), n=len(rr), area=float(A.sum()))
    names = sorted(set(r["object"] for r in rows))
    missing = [n for n in names if n not in objs]
    if missing:
        print("  shrad objects not matched:", missing)
    wl = [l for l in log.splitlines() if "warn" in l.lower() or "energy" in l or "reference:" in l]
    print(f"  shrad p={patches}: {len(rows)} patches, {time.time()-t0:.0f}s; " + " | ".join(wl), flush=True)
    return out
