"""The glTF bake, validated by the Khronos glTF-Validator and three.js's GLTFLoader (node,
validation/bake/validate.mjs) and, where a Python with bpy is given (SHRAD_BPY_PYTHON),
by Blender's importer (validation/bake/blender_check.py)."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import shrad
from conftest import room_dict

ROOT = Path(__file__).resolve().parents[3]
VALIDATION = ROOT / "validation" / "bake"


def node_check(*files):
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed (the bake's validators run in node)")
    if not (VALIDATION / "node_modules" / "gltf-validator").is_dir():
        pytest.fail("validation/bake/node_modules is missing: run scripts/setup-bake-validators (npm ci there)")
    out = subprocess.run(
        [node, str(VALIDATION / "validate.mjs"), *map(str, files)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    results = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    assert out.returncode == 0, (out.stdout, out.stderr)
    return results


@pytest.fixture(scope="module")
def lit(cornell):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    e.step()
    return e


def test_bake_passes_the_validator_and_loads_in_three(lit, cornell, tmp_path):
    glb = lit.export_gltf(tmp_path / "cornell.glb", exposure=1.5)
    gltf = lit.export_gltf(tmp_path / "cornell.gltf")
    assert (tmp_path / "cornell.bin").is_file()
    assert glb["exposure"] == 1.5 and gltf["exposure"] > 0
    assert glb["vertices"] == len(lit.vertex_colors)
    for r in node_check(tmp_path / "cornell.glb", tmp_path / "cornell.gltf"):
        assert r["validator"]["errors"] == 0, r["validator"]["messages"]
        assert r["validator"]["warnings"] == 0, r["validator"]["messages"]
        meshes = r["three"]["meshes"]
        assert sorted(m["name"] for m in meshes) == sorted(o.name for o in cornell.objects)
        for m in meshes:
            # Unlit: a MeshBasicMaterial drawing the vertex colours as they are.
            assert m["material"] == "MeshBasicMaterial" and m["vertexColors"], m
            assert m["color"] == 3 and m["radiosity"] == 3, m
            assert 0 < m["maxColour"] <= 1.0
        assert sum(m["vertices"] for m in meshes) == glb["vertices"]
        assert sum(m["triangles"] for m in meshes) == glb["triangles"]
        # _RADIOSITY is the radiosity B itself, unclamped.
        assert max(m["maxRadiosity"] for m in meshes) == pytest.approx(float(lit.vertex_colors.max()), rel=1e-5)


def test_an_animation_bakes_as_a_sequence(tmp_path):
    scene = shrad.load_dict(room_dict(patches=600, keyframes=True))
    e = shrad.Engine(scene, solver="dispersive", preset="default")
    baked = e.bake(tmp_path / "anim.glb", frames=3, passes=1)
    files = [Path(b["path"]) for b in baked]
    assert [f.name for f in files] == ["anim_0000.glb", "anim_0001.glb", "anim_0002.glb"]
    assert [b["time"] for b in baked] == [0.0, 0.5, 1.0]
    assert len({b["exposure"] for b in baked}) == 1  # one exposure for the sequence
    results = node_check(*files)
    block = [next(m for m in r["three"]["meshes"] if m["name"] == "block") for r in results]
    x0 = [b["bounds"][0][0] for b in block]
    assert x0[0] < x0[1] < x0[2], x0  # the block moves along +x through the files
    assert all(r["validator"]["errors"] == 0 for r in results)


def test_a_lightmap_bake_from_python(lit, tmp_path):
    # What `shrad bake --lightmap` writes: the atlas inside the glTF (valid, three.js loads
    # its uv1 and maps) and beside it, at the side asked for, in the format asked for.
    baked = lit.bake(tmp_path / "lm.glb", passes=0, lightmap=True, lightmap_res=128)
    assert baked[0]["lightmap_file"] == str(tmp_path / "lm.lightmap.exr"), baked
    assert baked[0]["lightmap_encoding"] == "linear OpenEXR, E / pi", baked
    atlas = shrad.read_exr(tmp_path / "lm.lightmap.exr")
    assert atlas.shape == (128, 128, 3) and np.isfinite(atlas).all()
    lit_texels = (atlas.max(axis=2) > 0).mean()
    assert 0.3 < lit_texels <= 1.0, lit_texels  # the charts fill the atlas (dilated)
    for r in node_check(tmp_path / "lm.glb"):
        assert r["validator"]["errors"] == 0, r["validator"]["messages"]
    rgbm = lit.bake(tmp_path / "rgbm.glb", passes=0, lightmap=True, texel_size=40.0, lightmap_format="rgbm")
    assert rgbm[0]["lightmap_file"] == str(tmp_path / "rgbm.lightmap.png"), rgbm
    assert rgbm[0]["lightmap_encoding"].startswith("RGBM PNG: E / pi = rgb * a * "), rgbm
    assert (tmp_path / "rgbm.lightmap.png").is_file() and not (tmp_path / "rgbm.lightmap.exr").exists()
    # The layout's arguments without a lightmap, or out of range: said, nothing written.
    before = sorted(tmp_path.iterdir())
    with pytest.raises(ValueError, match="lightmap_res applies to a lightmap: add lightmap=True"):
        lit.bake(tmp_path / "x.glb", lightmap_res=128)
    with pytest.raises(ValueError, match="lightmap_res 4: the atlas's side must be 8 to 16384"):
        lit.bake(tmp_path / "x.glb", lightmap=True, lightmap_res=4)
    with pytest.raises(ValueError, match="texel size must be a positive number"):
        lit.bake(tmp_path / "x.glb", lightmap=True, texel_size=-1.0)
    with pytest.raises(ValueError, match="unknown lightmap format 'png'"):
        lit.bake(tmp_path / "x.glb", lightmap=True, lightmap_format="png")
    with pytest.raises(ValueError, match="not both"):
        lit.bake(tmp_path / "x.glb", lightmap=True, texel_size=1.0, lightmap_res=64)
    assert sorted(tmp_path.iterdir()) == before


def test_bad_bake_paths_raise(lit, tmp_path):
    with pytest.raises(OSError, match=r"x\.png.*\.glb"):
        lit.export_gltf(tmp_path / "x.png")
    with pytest.raises(OSError, match="does not exist"):
        lit.export_gltf(tmp_path / "no" / "x.glb")
    with pytest.raises(ValueError, match="not animated"):
        lit.bake(tmp_path / "s.glb", frames=4)
    with pytest.raises(ValueError, match="exposure"):
        lit.export_gltf(tmp_path / "x.glb", exposure=-1)
    assert not list(tmp_path.iterdir())  # nothing left behind


def test_a_write_error_is_an_oserror_naming_the_file(lit, tmp_path):
    # A folder where the file should go: the write fails, not the input.
    (tmp_path / "taken.glb").mkdir()
    with pytest.raises(OSError, match=r"taken\.glb: cannot write"):
        lit.export_gltf(tmp_path / "taken.glb")
    (tmp_path / "taken.png").mkdir()
    with pytest.raises(OSError, match=r"taken\.png: cannot write"):
        shrad.write_png(tmp_path / "taken.png", np.zeros((2, 2, 3), np.float32))


def test_a_sequence_that_fails_partway_leaves_none_of_its_files(tmp_path):
    scene = shrad.load_dict(room_dict(patches=600, keyframes=True))
    e = shrad.Engine(scene, solver="dispersive", preset="default")
    # Frame 1 of 3 cannot be written (a folder has its name); frame 0 was, but goes again.
    (tmp_path / "anim_0001.glb").mkdir()
    with pytest.raises(OSError, match=r"anim_0001\.glb"):
        e.bake(tmp_path / "anim.glb", frames=3, passes=0)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["anim_0001.glb"]


@pytest.mark.skipif(not os.environ.get("SHRAD_BPY_PYTHON"), reason="SHRAD_BPY_PYTHON (a Python with bpy) not set")
def test_blender_imports_the_bake_with_its_colours(lit, tmp_path):
    path = tmp_path / "cornell.glb"
    lit.export_gltf(path)
    out = subprocess.run(
        [os.environ["SHRAD_BPY_PYTHON"], str(VALIDATION / "blender_check.py"), str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, (out.stdout[-2000:], out.stderr[-2000:])
    r = json.loads(next(line for line in out.stdout.splitlines() if line.startswith("{")))
    assert r["ok"] and len(r["meshes"]) == len(lit.objects)
    top = max(m["max_colour"] for m in r["meshes"])
    assert 0 < top <= 1.0 + 1e-6
    assert np.isfinite(top)


def test_a_bake_over_the_scene_file_being_read_is_refused(lit, tmp_path):
    # The engine that loaded room.glb baked over it; now an OSError names the file, and
    # the scene file is as it was.
    scene_file = tmp_path / "cornell.glb"
    lit.export_gltf(scene_file)
    before = scene_file.read_bytes()
    e = shrad.Engine(shrad.load(scene_file, patches=600), solver="dispersive", preset="default")
    for write in (e.export_gltf, e.bake, e.export_probes):
        with pytest.raises(OSError, match=r"cornell\.glb: cannot write: that is the scene file being read"):
            write(tmp_path / "." / "cornell.glb")
    assert e.frames == 0
    assert scene_file.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cornell.glb"]
