#!/usr/bin/env python3
"""Write the Cornell box the way other renderers' tooling does: every wall, box and the light
is a *unit* primitive (a [-1,1]^2 rectangle or a [-1,1]^3 cube) placed by its glTF node's
scale, rotation and translation. With --mirror every node also mirrors (scale x by -1) and
its mesh is spelled as glTF specifies for a negative determinant (the mesh mirrored, its
triangles reversed, i.e. clockwise front faces in the world). With --baked the same box has
its transforms applied to the vertices. Standard library only.

    python3 validation/cornell_unit_primitives.py out.gltf [--mirror | --baked]
"""
import base64, json, math, struct, sys

def quat_mul(a, b):
    ax, ay, az, aw = a; bx, by, bz, bw = b
    return [aw*bx + ax*bw + ay*bz - az*by, aw*by - ax*bz + ay*bw + az*bx,
            aw*bz + ax*by - ay*bx + az*bw, aw*bw - ax*bx - ay*by - az*bz]

def axis_angle(axis, deg):
    s = math.sin(math.radians(deg) / 2)
    return [axis[0]*s, axis[1]*s, axis[2]*s, math.cos(math.radians(deg) / 2)]

def rotate(q, v):
    x, y, z, w = q
    # v' = q v q*
    qv = quat_mul(quat_mul(q, [v[0], v[1], v[2], 0.0]), [-x, -y, -z, w])
    return qv[:3]

def apply(node, p):
    s, r, t = node["scale"], node["rotation"], node["translation"]
    q = rotate(r, [p[0]*s[0], p[1]*s[1], p[2]*s[2]])
    return [q[0]+t[0], q[1]+t[1], q[2]+t[2]]

# Unit rectangle in z = 0 facing +z; unit cube facing out. Counter-clockwise from the front.
RECT = ([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
def cube():
    pos, tri = [], []
    for axis in range(3):
        for sign in (-1, 1):
            n = [0, 0, 0]; n[axis] = sign
            u = [0, 0, 0]; u[(axis + 1) % 3] = 1
            v = [n[1]*u[2]-n[2]*u[1], n[2]*u[0]-n[0]*u[2], n[0]*u[1]-n[1]*u[0]]
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                pos.append([n[i] + a*u[i] + b*v[i] for i in range(3)])
            tri += [[base, base+1, base+2], [base, base+2, base+3]]
    return pos, tri
CUBE = cube()

W, H, D = 556.0, 548.8, 559.2
X = [1, 0, 0]; Y = [0, 1, 0]
def node(name, mesh, scale, rot, trans, colour, emit=None, role=None):
    return dict(name=name, mesh=mesh, scale=scale, rotation=rot, translation=trans,
                colour=colour, emit=emit, role=role)
white, red, green = [0.725, 0.71, 0.68], [0.63, 0.065, 0.05], [0.14, 0.45, 0.091]
PARTS = [
    # Rectangles face +z before rotation; the room's walls face inward.
    node("floor", RECT, [W/2, D/2, 1], axis_angle(X, -90), [W/2, 0, D/2], white, role="boundary"),
    node("ceiling", RECT, [W/2, D/2, 1], axis_angle(X, 90), [W/2, H, D/2], white, role="boundary"),
    node("back", RECT, [W/2, H/2, 1], axis_angle(Y, 180), [W/2, H/2, D], white, role="boundary"),
    # The camera looks down +z, so +x is on its left.
    node("left_red", RECT, [D/2, H/2, 1], axis_angle(Y, -90), [W, H/2, D/2], red, role="boundary"),
    node("right_green", RECT, [D/2, H/2, 1], axis_angle(Y, 90), [0, H/2, D/2], green, role="boundary"),
    node("light", RECT, [65, 52.5, 1], axis_angle(X, 90), [278, H - 0.5, 279.5], [0, 0, 0],
         emit=[17.0, 12.0, 4.0], role="light"),
    node("short_block", CUBE, [82.5, 82.5, 82.5], axis_angle(Y, -17), [185, 82.5, 169], white, role="interior"),
    node("tall_block", CUBE, [82.5, 165, 82.5], axis_angle(Y, 17), [368, 165, 351], white, role="interior"),
]

def main():
    out = sys.argv[1]
    mirror = "--mirror" in sys.argv
    baked = "--baked" in sys.argv
    bin_, views, accs, meshes, mats, nodes = bytearray(), [], [], [], [], []
    for k, p in enumerate(PARTS):
        pos, tri = p["mesh"]
        scale = list(p["scale"])
        if baked:
            pos = [apply(p, q) for q in pos]
        elif mirror:
            pos = [[-q[0], q[1], q[2]] for q in pos]
            tri = [[t[0], t[2], t[1]] for t in tri]
            scale[0] = -scale[0]
        off = len(bin_)
        for q in pos:
            bin_ += struct.pack("<3f", *q)
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(bin_) - off})
        lo = [min(q[i] for q in pos) for i in range(3)]
        hi = [max(q[i] for q in pos) for i in range(3)]
        accs.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(pos),
                     "type": "VEC3", "min": lo, "max": hi})
        off = len(bin_)
        for t in tri:
            bin_ += struct.pack("<3I", *t)
        views.append({"buffer": 0, "byteOffset": off, "byteLength": len(bin_) - off})
        accs.append({"bufferView": len(views) - 1, "componentType": 5125, "count": 3 * len(tri), "type": "SCALAR"})
        m = {"name": p["name"], "pbrMetallicRoughness": {"baseColorFactor": p["colour"] + [1.0],
             "metallicFactor": 0.0, "roughnessFactor": 1.0}}
        if p["emit"]:
            e = max(p["emit"])
            m["emissiveFactor"] = [c / e for c in p["emit"]]
            m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": e}}
        mats.append(m)
        meshes.append({"name": p["name"], "primitives": [{"attributes": {"POSITION": 2*k}, "indices": 2*k + 1, "material": k}]})
        n = {"name": p["name"], "mesh": k, "extras": {"shrad_role": p["role"]}}
        if not baked:
            n.update(scale=scale, rotation=p["rotation"], translation=p["translation"])
        nodes.append(n)
    cam = {"name": "camera", "camera": 0, "translation": [278, 273, -800], "rotation": [0, 1, 0, 0]}
    nodes.append(cam)
    gltf = {"asset": {"version": "2.0", "generator": "shrad validation/cornell_unit_primitives.py"},
            "extensionsUsed": ["KHR_materials_emissive_strength"],
            "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
            "meshes": meshes, "materials": mats, "accessors": accs, "bufferViews": views,
            "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(39.3), "znear": 1.0}}],
            "buffers": [{"byteLength": len(bin_), "uri": "data:application/octet-stream;base64," + base64.b64encode(bin_).decode()}]}
    with open(out, "w") as f:
        json.dump(gltf, f, indent=1)

main()
