#!/usr/bin/env python3
"""A scene with more kinds of data than the Cornell box, for the meshopt codecs: an
icosphere (642 vertices, smooth), a torus with UVs and 16-bit vertex colours whose
quaternion rotation is animated (keys with negative components), a floor and a lamp.
Exported by Blender's glTF exporter, then rewritten by gltfpack (npm, 1.x) each way:

    /tmp/bpyenv/bin/python rich.py -- rich.glb
    gltfpack -i rich.glb -o rich-cc-ext.glb -cc -ce ext -kn -km -ke -vc 16
    gltfpack -i rich.glb -o rich-cc-khr.glb -cc -ce khr -kn -km -ke -vc 16
    gltfpack -i rich.glb -o rich-noq-ext.glb -cc -noq -ce ext -kn -km -ke
    gltfpack -i rich.glb -o rich-noq-khr.glb -cc -noq -ce khr -kn -km -ke
    gltfpack -i rich.glb -o rich-vpf-ext.glb -cc -vpf -ce ext -kn -km -ke
    gltfpack -i rich.glb -o rich-vpf-khr.glb -cc -vpf -ce khr -kn -km -ke

(`-ce ext` writes EXT_meshopt_compression's version 0 streams, `-ce khr`
KHR_meshopt_compression's version 1 ones, over the same quantized data.)
"""
import math
import sys

import bpy
import mathutils
out = sys.argv[sys.argv.index("--")+1]
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
bpy.ops.mesh.primitive_plane_add(size=20, location=(0,0,0)); bpy.context.object.name="Floor"
bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=1.5, location=(-2,0,2)); s=bpy.context.object; s.name="Ball"
bpy.ops.object.shade_smooth()
bpy.ops.mesh.primitive_torus_add(location=(3,1,2), major_segments=40, minor_segments=16); t=bpy.context.object; t.name="Ring"
ca = t.data.color_attributes.new("Col", 'BYTE_COLOR', 'CORNER')
for i,d in enumerate(ca.data): d.color = ((i%7)/7, (i%11)/11, (i%13)/13, 1.0)
bpy.ops.object.select_all(action='DESELECT'); t.select_set(True); bpy.context.view_layer.objects.active=t
bpy.ops.object.mode_set(mode='EDIT'); bpy.ops.uv.smart_project(); bpy.ops.object.mode_set(mode='OBJECT')
sc.frame_start, sc.frame_end = 1, 48
t.rotation_mode='QUATERNION'
for f,ang,ax in [(1,0,(0,0,1)),(24,200,(1,-1,0.3)),(48,340,(-0.2,1,-1))]:
    t.rotation_quaternion = mathutils.Quaternion(mathutils.Vector(ax).normalized(), math.radians(ang))
    t.keyframe_insert("rotation_quaternion", frame=f)
bpy.ops.mesh.primitive_plane_add(size=3, location=(0,0,7), rotation=(math.pi,0,0)); l=bpy.context.object; l.name="Lamp"
m=bpy.data.materials.new("E"); m.use_nodes=True; b=m.node_tree.nodes["Principled BSDF"]; b.inputs["Emission Color"].default_value=(1,1,1,1); b.inputs["Emission Strength"].default_value=20
l.data.materials.append(m)
bpy.ops.export_scene.gltf(filepath=out, export_format='GLB', export_lights=False, export_cameras=False)
