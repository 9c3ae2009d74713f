# Independent skinning of Khronos SimpleSkin at rest, for tests/gltf_skin.rs (plain JSON,
# base64 and struct, no numpy): v' = sum_i w_i * (global(joint_i) * IBM_i) * v; the skinned
# node's own transform unused. Prints the bounds and vertices as published and with nodes[2]
# turned 90 degrees about +z at rest.
#     python3 simple_skin_rest.py SimpleSkin.gltf
import json, base64, struct, sys, math

def mat_mul(a, b):  # 4x4 row-major lists
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]

def trs(n):
    if 'matrix' in n:
        m = n['matrix']  # column-major
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    t = n.get('translation', [0, 0, 0]); x, y, z, w = n.get('rotation', [0, 0, 0, 1]); s = n.get('scale', [1, 1, 1])
    r = [[1 - 2 * (y*y + z*z), 2 * (x*y - z*w), 2 * (x*z + y*w)],
         [2 * (x*y + z*w), 1 - 2 * (x*x + z*z), 2 * (y*z - x*w)],
         [2 * (x*z - y*w), 2 * (y*z + x*w), 1 - 2 * (x*x + y*y)]]
    return [[r[i][0] * s[0], r[i][1] * s[1], r[i][2] * s[2], t[i]] for i in range(3)] + [[0, 0, 0, 1]]

def load(path, rotation=None):
    d = json.load(open(path))
    if rotation is not None:
        d['nodes'][2]['rotation'] = rotation
    bufs = [base64.b64decode(b['uri'].split(',', 1)[1]) for b in d['buffers']]
    def read(a):
        acc = d['accessors'][a]; v = d['bufferViews'][acc['bufferView']]
        comps = {'SCALAR': 1, 'VEC3': 3, 'VEC4': 4, 'MAT4': 16}[acc['type']]
        fmt, size = {5126: ('f', 4), 5123: ('H', 2), 5121: ('B', 1)}[acc['componentType']]
        stride = v.get('byteStride', comps * size)
        base = v.get('byteOffset', 0) + acc.get('byteOffset', 0)
        return [struct.unpack_from('<' + fmt * comps, bufs[v['buffer']], base + k * stride) for k in range(acc['count'])]
    parent = {c: p for p, n in enumerate(d['nodes']) for c in n.get('children', [])}
    def glob(k):
        m = trs(d['nodes'][k])
        return m if k not in parent else mat_mul(glob(parent[k]), m)
    skin = d['skins'][0]
    ibm = [[[m[c * 4 + r] for c in range(4)] for r in range(4)] for m in read(skin['inverseBindMatrices'])]
    J = [mat_mul(glob(j), ibm[i]) for i, j in enumerate(skin['joints'])]
    prim = d['meshes'][0]['primitives'][0]['attributes']
    out = []
    for p, js, ws in zip(read(prim['POSITION']), read(prim['JOINTS_0']), read(prim['WEIGHTS_0'])):
        q = [0.0, 0.0, 0.0]
        for j, w in zip(js, ws):
            for r in range(3):
                q[r] += w * (sum(J[j][r][c] * p[c] for c in range(3)) + J[j][r][3])
        out.append(q)
    return out

path = sys.argv[1]
h = math.sqrt(0.5)
for name, rot in [('as published', None), ('nodes[2] rotated 90 deg about z', [0, 0, h, h])]:
    pts = load(path, rot)
    lo = [min(p[i] for p in pts) for i in range(3)]; hi = [max(p[i] for p in pts) for i in range(3)]
    print(name, 'min', [round(x, 6) for x in lo], 'max', [round(x, 6) for x in hi])
    for k, p in enumerate(pts):
        print('  ', k, [round(x, 6) for x in p])
