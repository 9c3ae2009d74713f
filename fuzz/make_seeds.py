#!/usr/bin/env python3
"""Regenerate fuzz/seeds/ from scenes/ plus a few minimal hand-written inputs.

Run from anywhere: python3 fuzz/make_seeds.py. Needs only the standard library."""
import base64, json, os, re, struct

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "..", "scenes")
SEEDS = os.path.join(HERE, "seeds")


def put(target, name, data):
    d = os.path.join(SEEDS, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def read(name):
    with open(os.path.join(SCENES, name), "rb") as f:
        return f.read()


def glb(doc, bin_):
    """A GLB from a glTF document whose buffer 0 is `bin_` (uri removed)."""
    doc = json.loads(json.dumps(doc))
    doc["buffers"] = [{"byteLength": len(bin_)}]
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    bin_ = bin_ + b"\0" * (-len(bin_) % 4)
    total = 12 + 8 + len(text) + 8 + len(bin_)
    return (b"glTF" + struct.pack("<II", 2, total)
            + struct.pack("<I", len(text)) + b"JSON" + text
            + struct.pack("<I", len(bin_)) + b"BIN\0" + bin_)


def from_data_uri(doc):
    uri = doc["buffers"][0]["uri"]
    return base64.b64decode(uri.split(";base64,", 1)[1])


def tri_doc(mode=None, indexed=True, extras=None, emissive=False, scene=True):
    """One triangle (or a quad as a strip/fan of four vertices) as glTF with a data URI."""
    pos = [0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0]
    pbytes = struct.pack("<12f", *pos)
    strip = mode in (5, 6)
    ibytes = struct.pack("<4H", 0, 1, 2, 3) if strip else struct.pack("<6H", 0, 1, 2, 2, 1, 3)
    data = pbytes + ibytes + b"\0" * (-len(ibytes) % 4)
    prim = {"attributes": {"POSITION": 0}, "material": 0}
    if indexed:
        prim["indices"] = 1
    if mode is not None:
        prim["mode"] = mode
    mat = {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}}
    if emissive:
        mat["emissiveFactor"] = [1, 1, 1]
        mat["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}
        mat["doubleSided"] = True
    node = {"mesh": 0, "name": "n", "translation": [0, 0, 1], "children": [1]}
    child = {"mesh": 0, "scale": [-1, 1, 1], "camera": 0}
    if extras:
        node["extras"] = extras
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": len(ibytes)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5123, "count": len(ibytes) // 2, "type": "SCALAR"}],
        "materials": [mat],
        "meshes": [{"name": "m", "primitives": [prim]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "aspectRatio": 1.5}}],
        "nodes": [node, child],
    }
    if scene:
        doc["scenes"] = [{"nodes": [0]}]
        doc["scene"] = 0
    return doc


def png(w, h, rgb):
    """A tiny 8-bit RGB PNG of one colour."""
    import zlib
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    raw = b"".join(b"\0" + bytes(rgb) * w for _ in range(h))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def textured(doc, in_buffer):
    """`doc` with a 2 x 2 PNG base colour texture, as a data URI or in buffer view 2."""
    doc = json.loads(json.dumps(doc))
    img = png(2, 2, (200, 100, 50))
    if in_buffer:
        data = from_data_uri(doc)
        off = len(data)
        data += img + b"\0" * (-len(img) % 4)
        doc["buffers"][0] = {"byteLength": len(data),
                             "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}
        doc["bufferViews"].append({"buffer": 0, "byteOffset": off, "byteLength": len(img)})
        doc["images"] = [{"bufferView": 2, "mimeType": "image/png"}]
    else:
        doc["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(img).decode()}]
    doc["textures"] = [{"source": 0}]
    doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    return doc


# glTF (JSON text)
cornell = json.loads(read("cornell.gltf"))
put("gltf", "cornell.gltf", json.dumps(cornell, separators=(",", ":")))
put("gltf", "tri.gltf", json.dumps(tri_doc()))
put("gltf", "strip.gltf", json.dumps(tri_doc(mode=5, extras={"shrad_role": "light", "shrad_patch_size": 0.5}, emissive=True)))
put("gltf", "fan_noindex_noscene.gltf", json.dumps(tri_doc(mode=6, indexed=False, scene=False)))
put("gltf", "texture.gltf", json.dumps(textured(tri_doc(), False)))
put("gltf", "minimal.gltf", '{"asset":{"version":"2.0"}}')

# The compressed and quantized fixtures (gltfpack, gltf-pipeline; see docs/results.md §11):
# as they are for glb, and as .gltf text with the BIN chunk as a data URI for gltf.
COMPRESSED = os.path.join(HERE, "..", "crates", "shrad-scene", "tests", "data", "compressed")


def glb_to_gltf(data):
    """The JSON of a GLB with its BIN chunk as buffer 0's data URI."""
    n = struct.unpack("<I", data[12:16])[0]
    doc = json.loads(data[20:20 + n])
    rest = data[20 + n:]
    bin_ = rest[8:8 + struct.unpack("<I", rest[:4])[0]] if len(rest) >= 8 else b""
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bin_).decode()
    return doc


for name in ["cornell-quant.glb", "cornell-meshopt.glb", "cornell-meshopt-cc.glb", "cornell-draco.glb"]:
    with open(os.path.join(COMPRESSED, name), "rb") as f:
        data = f.read()
    put("glb", name, data)
    put("gltf", name.replace(".glb", ".gltf"), json.dumps(glb_to_gltf(data), separators=(",", ":")))

# What the specification allows and files from the validator's suite do: no scene and no
# node (a library of meshes), positions as an accessor without bufferView (zeros) with
# sparse values on top, an accessor of a type glTF 2.0 does not define (unused), version 2.1.
sp_idx = struct.pack("<3H", 0, 1, 2) + b"\0\0"
sp_val = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
data = sp_idx + sp_val
put("gltf", "library_sparse_zeros.gltf", json.dumps({
    "asset": {"version": "2.1", "minVersion": "2.0"},
    "buffers": [{"byteLength": len(data),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
    "bufferViews": [{"buffer": 0, "byteLength": 6}, {"buffer": 0, "byteOffset": 8, "byteLength": 36}],
    "accessors": [{"componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0],
                   "sparse": {"count": 3, "indices": {"bufferView": 0, "componentType": 5123},
                              "values": {"bufferView": 1}}},
                  {"componentType": 5126, "count": 2, "type": "NotaVEC3"}],
    "materials": [{"emissiveFactor": [1, 1, 1]}],
    "meshes": [{"name": "m", "primitives": [{"attributes": {"POSITION": 0}, "material": 0, "mode": 6}]}],
}))

# GLB (binary)
put("glb", "cornell.glb", glb(cornell, from_data_uri(cornell)))
for name, doc in [("tri.glb", tri_doc()), ("strip.glb", tri_doc(mode=5, emissive=True)),
                  ("texture.glb", textured(tri_doc(), True))]:
    put("glb", name, glb(doc, from_data_uri(doc)))

# OBJ + MTL: obj text, NUL, mtl text; the library is named m.mtl
obj = read("cornell.obj").replace(b"mtllib cornell.mtl", b"mtllib m.mtl")
put("obj", "cornell", obj + b"\0" + read("cornell.mtl"))
put("obj", "l_block", read("l_block.obj"))
put("obj", "tri", "mtllib m.mtl\no t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nusemtl a\nf 1/1/1 2/1/1 3/1/1\n"
    "usemtl b\nf -3 -2 -1\ng g2\nl 1 2\np 1\n\0newmtl a\nKd 0.5\nKe 1 2 3\nnewmtl b\nKd 0.1 0.2 0.3\nillum 1\n")
put("obj", "quad_nomtl", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")

# TOML scene files: primitives only (the ones that name other files keep them; an error)
for name in sorted(os.listdir(SCENES)):
    if name.endswith(".toml"):
        put("toml", name, read(name))
ex = read("example.toml").decode()
ex = re.sub(r'\[\[object\]\]\nname = "tall_block".*?(?=\n\[\[object\]\]|\Z)', "", ex, flags=re.S)
put("toml", "example_primitives.toml", ex)
put("toml", "self.toml", '[[object]]\nshape = "mesh"\nfile = "s.toml"\n')
put("toml", "minimal.toml", '[[object]]\nshape = "quad"\ncorners = [[0,0,0],[1,0,0],[1,1,0],[0,1,0]]\n')
