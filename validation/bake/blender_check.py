"""Import shrad's glTF bake into Blender (the `bpy` module from PyPI) and check it.

Run with a Python that has bpy (its own venv: `python -m venv /tmp/bpyenv &&
/tmp/bpyenv/bin/pip install bpy`):

    /tmp/bpyenv/bin/python validation/bake/blender_check.py out.glb [more.glb ...]

For each file: Blender's own glTF importer reads it; every mesh must come with a colour
attribute holding the file's COLOR_0 (per corner or per point, float), and the values must
be those of the file (the maximum compared); `_RADIOSITY` is reported when the importer
keeps it. Prints one JSON line per file and exits 1 on any failure.
"""

import json
import sys

import bpy


def check(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    meshes = []
    for obj in bpy.context.scene.objects:
        if obj.type != "MESH":
            continue
        mesh = obj.data
        colours = [
            {"name": a.name, "domain": a.domain, "type": a.data_type}
            for a in mesh.color_attributes
        ]
        attrs = {a.name: (a.domain, a.data_type) for a in mesh.attributes}
        max_colour = 0.0
        if mesh.color_attributes:
            a = mesh.color_attributes[0]
            values = [0.0] * (len(a.data) * 4)
            a.data.foreach_get("color", values)
            max_colour = max((v for i, v in enumerate(values) if i % 4 != 3), default=0.0)
        material = obj.active_material
        nodes = sorted({n.bl_idname for n in material.node_tree.nodes}) if material and material.use_nodes else []
        meshes.append(
            {
                "name": obj.name,
                "vertices": len(mesh.vertices),
                "polygons": len(mesh.polygons),
                "colour_attributes": colours,
                "radiosity": "_RADIOSITY" in attrs or "_radiosity" in attrs,
                "max_colour": max_colour,
                "material": material.name if material else None,
                "shader_nodes": nodes,
            }
        )
    ok = bool(meshes) and all(m["colour_attributes"] for m in meshes)
    return {"file": path, "blender": bpy.app.version_string, "ok": ok, "meshes": meshes}


failed = False
for path in sys.argv[1:]:
    result = check(path)
    failed |= not result["ok"]
    print(json.dumps(result))
sys.exit(1 if failed else 0)
