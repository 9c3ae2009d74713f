"""Import shrad's lightmapped glTF (`shrad bake SCENE --lightmap`) with Blender's own glTF
importer (the `bpy` module from PyPI) and check what a Blender user would get.

Run with a Python that has bpy, in its own venv outside the repository:

    python3.11 -m venv /tmp/bpy-venv && /tmp/bpy-venv/bin/pip install bpy
    shrad bake cornell --lightmap --lightmap-res 256 -o /tmp/lm/cornell.glb
    nice -n 19 /tmp/bpy-venv/bin/python validation/bake/blender_import.py /tmp/lm/cornell.glb

Checks, per file:
- every mesh has two UV layers (the file's TEXCOORD_0 and TEXCOORD_1), the second's
  coordinates inside [0, 1];
- the image the material uses is loaded (`lit`, the lightmap times the albedo, width x
  height as the file's `asset.extras.shrad.lightmap` says) and holds light: most of its
  pixels are not black. (The bare `lightMap` image is named only in the material's extras,
  for three.js; no glTF importer reads extras, so Blender does not load it: it is reported
  when present, not required.)
- every mesh's material is the file's unlit material and its shader reads the `lit`
  image through a UV Map node on the second UV layer (TEXCOORD_1), as the file says.

Prints one JSON line per file and exits 1 on any failure.
"""

import json
import struct
import sys

import bpy


def glb_json(path):
    """The JSON chunk of a GLB (or the whole of a .gltf)."""
    data = open(path, "rb").read()
    if data[:4] != b"glTF":
        return json.loads(data)
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20 : 20 + length])


def image_report(image):
    """Size and how many pixels are not black (RGB above 1/255)."""
    width, height = image.size
    pixels = [0.0] * (width * height * 4)
    image.pixels.foreach_get(pixels)
    lit = sum(1 for k in range(0, len(pixels), 4) if max(pixels[k : k + 3]) > 1.0 / 255.0)
    return {"name": image.name, "size": [width, height], "lit_fraction": lit / max(1, width * height)}


def uv_map_of_image_node(material, images):
    """The UV layers the material's image texture nodes of `images` read (via UV Map nodes),
    and which of the images they show."""
    reads, shown = [], set()
    for node in material.node_tree.nodes:
        if node.bl_idname != "ShaderNodeTexImage" or node.image is None:
            continue
        if node.image.name not in images:
            continue
        shown.add(node.image.name)
        for link in node.inputs["Vector"].links:
            src = link.from_node
            # Blender puts a Mapping node between when a texture transform is present.
            while src.bl_idname != "ShaderNodeUVMap" and src.inputs and src.inputs[0].links:
                src = src.inputs[0].links[0].from_node
            if src.bl_idname == "ShaderNodeUVMap":
                reads.append(src.uv_map)
    return reads, shown


def check(path):
    root = glb_json(path)
    want = root["asset"]["extras"]["shrad"]["lightmap"]
    size = [want["width"], want["height"]]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    images = {i.name: image_report(i) for i in bpy.data.images if i.size[0] > 0}
    problems = []
    # The `lightMap` image is referenced only from the material's extras (for three.js),
    # which no glTF importer reads: Blender loads the `lit` one, the one the material uses.
    for name in ("lit",):
        matches = [r for n, r in images.items() if n.startswith(name)]
        if not matches:
            problems.append(f"image {name} not loaded")
        elif matches[0]["size"] != size:
            problems.append(f"image {name} is {matches[0]['size']}, the file says {size}")
        elif matches[0]["lit_fraction"] < 0.5:
            problems.append(f"image {name}: only {matches[0]['lit_fraction']:.2f} of its pixels are lit")
    meshes = []
    for obj in bpy.context.scene.objects:
        if obj.type != "MESH":
            continue
        mesh = obj.data
        layers = [uv.name for uv in mesh.uv_layers]
        uv1 = [0.0] * (2 * len(mesh.loops))
        if len(layers) >= 2:
            mesh.uv_layers[1].data.foreach_get("uv", uv1)
        material = obj.active_material
        reads, shown = uv_map_of_image_node(material, images) if material and material.node_tree else ([], set())
        m = {
            "name": obj.name,
            "uv_layers": layers,
            "uv1_in_0_1": all(-1e-6 <= x <= 1.0 + 1e-6 for x in uv1),
            "material": material.name if material else None,
            "images_shown": sorted(shown),
            "uv_maps_read": sorted(set(reads)),
        }
        meshes.append(m)
        if len(layers) != 2:
            problems.append(f"{obj.name}: {len(layers)} UV layers")
        elif not m["uv1_in_0_1"]:
            problems.append(f"{obj.name}: second UV layer outside [0, 1]")
        if not any(s.startswith("lit") for s in shown):
            problems.append(f"{obj.name}: its material shows no lit image")
        if len(layers) == 2 and reads and set(reads) != {layers[1]}:
            problems.append(f"{obj.name}: the image is read through {reads}, not {layers[1]}")
        if not reads:
            problems.append(f"{obj.name}: no UV Map node feeds the image (it would read the first layer)")
    if not meshes:
        problems.append("no meshes")
    return {
        "file": path,
        "blender": bpy.app.version_string,
        "ok": not problems,
        "problems": problems,
        "images": list(images.values()),
        "meshes": meshes,
    }


failed = False
for path in sys.argv[1:]:
    result = check(path)
    failed |= not result["ok"]
    print(json.dumps(result))
sys.exit(1 if failed else 0)
