"""The API over the engine: loading, steering, reading arrays, pictures, errors."""

import math

import numpy as np
import pytest

import shrad
from conftest import box_mesh, room_dict


def test_load_builtin_lists_objects(cornell):
    names = [o.name for o in cornell.objects]
    assert "short_block" in names and "tall_block" in names
    roles = {o.name: o.role for o in cornell.objects}
    assert roles["short_block"] == "interior"
    assert "light" in roles.values() and "boundary" in roles.values()
    for o in cornell.objects:
        lo, hi = o.bounds
        assert all(a <= b for a, b in zip(lo, hi)), o
        assert o.triangles > 0
    assert cornell.patching == ("count", 1500.0)
    assert "cornell" in cornell.source
    # The library's built-in scenes, each of which loads by its name.
    assert shrad.builtins() == ["cornell", "room"]
    assert all(len(shrad.load(name, patches=200).objects) > 0 for name in shrad.builtins())


def test_engine_arrays_have_shapes_and_dtypes(cornell):
    e = shrad.Engine(cornell, solver="dispersive", preset="default")
    n = len(e)
    assert n > 1000
    stats = e.step()
    assert isinstance(stats, dict) and stats["frame_ms"] > 0
    B = e.radiosity
    assert B.shape == (n, 3) and B.dtype == np.float32 and B.flags["C_CONTIGUOUS"]
    assert np.isfinite(B).all() and B.max() > 0
    assert e.centres.shape == (n, 3) and e.centres.dtype == np.float32
    normals = e.normals
    assert normals.shape == (n, 3)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-4)
    assert e.areas.shape == (n,) and e.areas.dtype == np.float32 and (e.areas > 0).all()
    ids = e.object_ids
    assert ids.shape == (n,) and ids.dtype == np.uint32
    assert set(np.unique(ids)) == set(range(len(cornell.objects)))
    vc = e.vertex_colors
    assert vc.ndim == 2 and vc.shape[1] == 3 and vc.dtype == np.float32
    # The arrays are the engine's state at the time of reading: a step moves on, the
    # array read before does not change under the caller.
    before = B.copy()
    e.step()
    np.testing.assert_array_equal(B, before)


def test_radiosity_matches_the_lights_emission_on_light_patches(cornell):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    lights = [o.index for o in cornell.objects if o.role == "light"]
    on_light = np.isin(e.object_ids, lights)
    radiance = np.array([2.0, 3.0, 5.0], np.float32)
    for i in lights:
        e.set_emission(i, radiance)
    e.step()
    B = e.radiosity[on_light]
    # A Lambertian emitter of radiance L has exitance pi L; the light's radiosity is that
    # plus what it reflects, rho H, which is less than what it emits (it sees the dimmer room).
    exitance = np.pi * radiance
    reflected = B - exitance
    assert (reflected >= -1e-4 * exitance).all(), reflected.min(axis=0)
    assert (reflected < exitance).all(), reflected.max(axis=0)
    # The transport is linear in the emission: twice the radiance, twice the radiosity.
    for i in lights:
        e.set_emission(i, 2 * radiance)
    e.step()
    np.testing.assert_allclose(e.radiosity[on_light], 2 * B, rtol=1e-4)


def test_transform_round_trip_and_names_or_indices(cornell):
    e = shrad.Engine(cornell)
    i = [o.name for o in cornell.objects].index("short_block")
    m = e.transform("short_block")
    assert m.shape == (4, 4) and m.dtype == np.float64
    np.testing.assert_array_equal(m, e.transform(i))
    moved = m.copy()
    moved[:3, 3] += [10.0, 0.0, 0.0]
    e.set_transform("short_block", moved)
    np.testing.assert_allclose(e.transform(i), moved, atol=1e-4)
    # A list of lists is an array too.
    e.set_transform(i, m.tolist())
    np.testing.assert_allclose(e.transform("short_block"), m, atol=1e-4)
    centre = e.centres[e.object_ids == i].mean(axis=0)
    lo, hi = cornell.objects[i].bounds
    np.testing.assert_allclose(centre, (np.array(lo) + np.array(hi)) / 2, atol=1.0)


def test_emission_switches_the_light_off(cornell):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    light = next(o.name for o in cornell.objects if o.role == "light")
    e.step()
    lit = e.radiosity.sum()
    e.set_emission(light, [0.0, 0.0, 0.0])
    e.step()
    assert e.radiosity.sum() < 1e-6 * lit


def test_a_wall_painted_another_colour_reflects_it(cornell):
    # The red wall painted a grey of 0.5: its radiosity is 0.5 times what it receives, so
    # each channel's ratio to the old one is 0.5 / rho_old (the light it receives from the
    # rest of the box changes only slightly: the reference is converged each step).
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    wall = next(o.index for o in cornell.objects if o.name == "left_red")
    on_wall = e.object_ids == wall
    e.step()
    before = e.radiosity[on_wall].sum(axis=0)
    e.set_reflectance("left_red", [0.5, 0.5, 0.5])
    e.step()
    after = e.radiosity[on_wall].sum(axis=0)
    # Red was 0.63: a grey of 0.5 reflects less red; green and blue were 0.065 and 0.05.
    assert after[0] < 0.85 * before[0]
    assert after[1] > 5 * before[1] and after[2] > 5 * before[2]
    with pytest.raises(ValueError, match="reflectance"):
        e.set_reflectance(wall, [0.5, 1.5, 0.5])
    with pytest.raises(ValueError, match="reflectance"):
        e.set_reflectance(wall, [math.nan, 0.5, 0.5])


def test_settings_are_the_engines_keys(cornell):
    e = shrad.Engine(cornell, "dispersive", "paper", cube_res=16, schedule="full")
    assert e.option("cube_res") == "16"
    assert e.option("schedule") == "full"
    assert len(e.step()["objects_updated"]) == sum(o.role == "interior" for o in cornell.objects)
    assert e.set_option("schedule", "round_robin") is None  # live, no precomputation
    # A key that needs the precomputation again rebuilds it and says what it cost.
    ms = e.set_option("cube_res", 8)
    assert isinstance(ms, float) and math.isfinite(ms)
    assert e.option("cube_res") == "8"
    assert len(e.step()["objects_updated"]) > 0
    keys = {d["name"] for d in shrad.options("dispersive")}
    assert {"cube_res", "bands", "schedule"} <= keys
    assert dict(e.settings)["cube_res"] == "8"
    assert shrad.presets("dispersive")[0] == "default"


def test_render_is_linear_float32(cornell):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    e.step()
    img = e.render(48, 32, spp=1)
    assert img.shape == (32, 48, 3) and img.dtype == np.float32
    assert np.isfinite(img).all() and img.max() > 0
    cam = {"eye": [278, 273, -800], "target": [278, 273, 0], "yfov_deg": 39}
    other = e.render(16, 16, spp=1, camera=cam, shading="flat")
    assert other.shape == (16, 16, 3)


def test_images_round_trip_through_exr(tmp_path, cornell):
    img = np.random.default_rng(1).random((8, 12, 3), dtype=np.float32) * 3
    path = tmp_path / "x.exr"
    shrad.write_exr(path, img)
    np.testing.assert_array_equal(shrad.read_exr(path), img)
    shrad.write_png(tmp_path / "x.png", img, exposure=0.5)
    shrad.write_png(str(tmp_path / "y.png"), img.astype(np.float64), tonemap="minmax")
    assert (tmp_path / "x.png").stat().st_size > 0 and (tmp_path / "y.png").exists()


def test_load_dict_round_trip():
    d = room_dict(patches=800)
    s = shrad.load_dict(d)
    assert [o.name for o in s.objects] == ["room", "lamp", "block"]
    assert [o.role for o in s.objects] == ["boundary", "light", "interior"]
    lo, hi = s.objects[2].bounds
    np.testing.assert_allclose(lo, [-0.9, 0.0, -0.3], atol=1e-5)
    np.testing.assert_allclose(hi, [-0.3, 0.6, 0.3], atol=1e-5)
    assert s.source == "py-room" and s.patching == ("count", 800.0)
    e = shrad.Engine(s, solver="reference", preset="fast")
    e.step()
    on_block = e.object_ids == 2
    # Lit by the lamp and the walls, but for the face resting on the floor.
    assert e.radiosity[on_block & (e.normals[:, 1] > -0.5)].min() > 0
    assert e.radiosity[on_block & (e.normals[:, 1] < -0.5)].max() < 1e-6


def test_load_dict_transform_colours_and_keyframes():
    pos, tris = box_mesh((0.2, 0.2, 0.2))
    m = np.eye(4)
    m[:3, 3] = [0.5, 0.2, 0.5]
    d = room_dict(patches=600, keyframes=True)
    d["objects"].append(
        {
            "name": "tinted",
            "shape": "mesh",
            "positions": pos.astype(np.float64),  # converted
            "triangles": tris.astype(np.int32),
            "colors": np.tile([[1.0, 0.25, 0.25]], (len(pos), 1)),  # times the reflectance
            "reflectance": [0.8, 0.8, 0.8],
            "transform": m,
        }
    )
    s = shrad.load_dict(d)
    assert s.duration == pytest.approx(1.0)
    assert [o.animated for o in s.objects] == [False, False, True, False]
    lo, hi = s.objects[3].bounds
    np.testing.assert_allclose(lo, [0.3, 0.0, 0.3], atol=1e-5)
    e = shrad.Engine(s, solver="reference", preset="fast")
    e.set_time(1.0)
    np.testing.assert_allclose(e.transform("block")[:3, 3], [0.6, 0.3, 0.0], atol=1e-4)
    assert e.time == 1.0
    e.step()
    red = e.reflectance[e.object_ids == 3]
    np.testing.assert_allclose(red.mean(axis=0), [0.8, 0.2, 0.2], atol=1e-3)


SAME_SCENE_TOML = """
[camera]
eye = [0, 1.2, -1.9]
target = [0, 1.0, 0]
yfov_deg = 60

[settings]
patches = 700

[[object]]
name = "room"
shape = "box"
size = [3, 2.5, 4]
inward = true
role = "boundary"
position = [0, 1.25, 0]
reflectance = [0.7, 0.7, 0.7]

[[object]]
name = "lamp"
shape = "quad"
corners = [[-0.4, 2.49, -0.4], [0.4, 2.49, -0.4], [0.4, 2.49, 0.4], [-0.4, 2.49, 0.4]]
emission = [8, 8, 8]

[[object]]
name = "ball"
shape = "sphere"
radius = 0.3
segments = 12
position = [0.5, 0.3, 0.2]
rotation_quat = [0, 0.3826834, 0, 0.9238795]
scale = [1, 0.8, 1]
reflectance = [0.2, 0.6, 0.3]
interpolation = "step"
[[object.key]]
time = 0
[[object.key]]
time = 1
translation = [-0.5, 0, 0]
rotation_deg = [0, 90, 0]
[[object.emission_key]]
time = 0.5
emission = [0.1, 0, 0]
[[object.reflectance_key]]
time = 1
reflectance = [0.1, 0.2, 0.7]

[[object]]
name = "block"
shape = "mesh"
file = "block.obj"
reflectance = [0.6, 0.5, 0.4]
position = [-0.6, 0.3, 0.0]
"""


LIGHTS_TOML = """
[[lights]]
name = "bulb"
kind = "point"
position = [0.5, 2.0, 0.5]
power = 40

[[lights]]
name = "spot"
kind = "spot"
position = [0, 2.4, 0]
direction = [0, -1, 0]
power = 200
outer_cone_deg = 35
blend = 0.25
"""

LIGHTS_DICT = [
    {"name": "bulb", "kind": "point", "position": [0.5, 2.0, 0.5], "power": 40},
    {"name": "spot", "kind": "spot", "position": [0, 2.4, 0], "direction": [0, -1, 0],
     "power": 200, "outer_cone_deg": 35, "blend": 0.25},
]


def test_a_dicts_lights_are_a_scene_files_lights(tmp_path):
    """``load_dict`` takes ``lights`` with the keys of ``[[lights]]``: the same light, and the
    same mistakes refused with the same words."""
    room = room_dict()["objects"][0]  # the walls alone: no lamp, no block
    (tmp_path / "lit.toml").write_text(
        '[settings]\npatches = 500\n\n[[object]]\nname = "room"\nshape = "box"\nsize = [3, 2.5, 4]\n'
        'inward = true\nrole = "boundary"\nposition = [0, 1.25, 0]\nreflectance = [0.7, 0.7, 0.7]\n'
        + LIGHTS_TOML
    )
    from_file = shrad.load(tmp_path / "lit.toml")
    from_dict = shrad.load_dict({"settings": {"patches": 500}, "objects": [room], "lights": LIGHTS_DICT})
    radiosity = []
    for s in (from_file, from_dict):
        e = shrad.Engine(s, solver="reference", preset="fast")
        e.step()
        radiosity.append(e.radiosity)
    assert radiosity[0].max() > 0, "the lights light the room"
    np.testing.assert_array_equal(radiosity[0], radiosity[1])
    e.set_light("spot", intensity=0.0)  # found by its name
    bad = dict(LIGHTS_DICT[1], inner_cone_deg=10)
    with pytest.raises(ValueError, match=r"lights 1: give inner_cone_deg or blend \(Blender's\), not both"):
        shrad.load_dict({"objects": [room], "lights": [LIGHTS_DICT[0], bad]})
    with pytest.raises(ValueError, match="lights 1: the name 'bulb' is already light 0's"):
        shrad.load_dict({"objects": [room], "lights": [LIGHTS_DICT[0], LIGHTS_DICT[0]]})
    with pytest.raises(ValueError, match="lights 0: .*unknown field `watts`"):
        shrad.load_dict({"objects": [room], "lights": [{"kind": "point", "watts": 3}]})
    with pytest.raises(ValueError, match="'lights' must be a list of dicts"):
        shrad.load_dict({"objects": [room], "lights": LIGHTS_DICT[0]})


def test_a_toml_file_and_a_dict_make_the_same_scene(tmp_path):
    pos, tris = box_mesh((0.3, 0.3, 0.3))
    obj = tmp_path / "block.obj"
    obj.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in pos) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in tris))
    (tmp_path / "scene.toml").write_text(SAME_SCENE_TOML)
    from_file = shrad.load(tmp_path / "scene.toml")
    room = room_dict(patches=700)
    ball = {
        "name": "ball",
        "shape": "sphere",
        "radius": 0.3,
        "segments": 12,
        "position": (0.5, 0.3, 0.2),
        "rotation_quat": np.array([0, 0.3826834, 0, 0.9238795]),
        "scale": [1, 0.8, 1],
        "reflectance": [0.2, 0.6, 0.3],
        "interpolation": "step",
        "key": [{"time": 0}, {"time": 1, "translation": [-0.5, 0, 0], "rotation_deg": [0, 90, 0]}],
        "emission_key": [{"time": 0.5, "emission": [0.1, 0, 0]}],
        "reflectance_key": [{"time": 1, "reflectance": [0.1, 0.2, 0.7]}],
    }
    block = {
        "name": "block",
        "shape": "mesh",
        "file": obj,  # a path object, relative paths from the working directory
        "reflectance": [0.6, 0.5, 0.4],
        "position": [-0.6, 0.3, 0.0],
    }
    from_dict = shrad.load_dict({**room, "objects": room["objects"][:2] + [ball, block]})

    def described(scene):
        return [(o.name, o.role, o.bounds, o.triangles, o.animated) for o in scene.objects]

    assert described(from_file) == described(from_dict)
    assert [o.name for o in from_file.objects] == ["room", "lamp", "ball", "block"]
    assert (from_file.duration, from_file.patching) == (from_dict.duration, from_dict.patching) == (1.0, ("count", 700.0))
    engines = [shrad.Engine(s, solver="reference", preset="fast") for s in (from_file, from_dict)]
    for e in engines:
        e.set_time(0.75)  # step keys: the ball holds its first key, and glows
        e.step()
    a, b = engines
    np.testing.assert_array_equal(a.centres, b.centres)
    np.testing.assert_array_equal(a.reflectance, b.reflectance)
    # The ball's own reflectance holds until its one reflectance key (at 1 s, step keys):
    # given both, the key painted it from the start and its own value was ignored.
    np.testing.assert_allclose(a.reflectance[a.object_ids == 2], [[0.2, 0.6, 0.3]] * int((a.object_ids == 2).sum()), rtol=1e-6)
    np.testing.assert_array_equal(a.transform("ball"), b.transform("ball"))
    np.testing.assert_array_equal(a.radiosity, b.radiosity)
    # The same camera too: the scene's camera renders the same picture.
    np.testing.assert_array_equal(a.render(24, 16, spp=1), b.render(24, 16, spp=1))


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["objects"][2].update(shape="cone"), "object 2 'block': shape: unknown variant `cone`"),
        (lambda d: d["objects"][1].update(colour=[1, 1, 1]), "object 1 'lamp': unknown field `colour`"),
        (lambda d: d["objects"][0].update(corners=[[0, 0, 0]] * 4), "'corners' does not apply to shape 'box'"),
        (lambda d: d["objects"][2].update(triangles=np.array([[0, 1, 99]])), "vertex index 99 out of range"),
        (lambda d: d["objects"][2].update(positions=np.zeros((4, 2))), "'positions' must be an (N, 3) array of numbers: got shape [4, 2]"),
        (lambda d: d["objects"][2].update(positions=np.zeros(72)), "'positions' must be an (N, 3) array of numbers: got shape [72]"),
        (lambda d: d["objects"][2].update(positions=np.zeros((24, 3), complex)), "numbers: got dtype complex128"),
        # Float indices were truncated (0.7 -> 0), NaN became index -9223372036854775808.
        (lambda d: d["objects"][2].update(triangles=d["objects"][2]["triangles"] + 0.7), "integers: got dtype float64"),
        (lambda d: d["objects"][2].update(triangles=np.ones((2, 3), bool)), "integers: got dtype bool"),
        (lambda d: d["objects"][2].update(triangles=np.array([[0, 1, 2**64 - 1]], np.uint64)), "vertex index 18446744073709551615 out of range"),
        (lambda d: d["objects"][2].update(triangles=np.array([[0, 1, -1]])), "'triangles': triangle 0 has vertex index -1 out of range (24 vertices)"),
        (lambda d: d["objects"][1].update(emission=[-1, 0, 0]), "emission must be >= 0"),
        (lambda d: d["objects"][2].update(reflectance=[1.5, 0, 0]), "reflectance [1.5, 0, 0] must be within [0, 1]"),
        (lambda d: d["objects"][2].update(key=[{"time": math.inf}]), "key 0: time must be finite"),
        (lambda d: d.update(objects=[]), "no objects"),
    ],
)
def test_bad_dicts_raise_value_error_naming_what(change, message):
    d = room_dict()
    change(d)
    with pytest.raises(ValueError, match="py-room") as info:
        shrad.load_dict(d)
    assert message in str(info.value)
    assert "Error:" not in str(info.value), "a message, not a nested exception's repr"


def test_a_dict_names_its_name_when_it_is_no_string():
    with pytest.raises(TypeError, match="the scene's 'name' must be a string, got 3"):
        shrad.load_dict({**room_dict(), "name": 3})


def test_a_gltf_without_its_bin_is_file_not_found_naming_both(tmp_path):
    engine = shrad.Engine(shrad.load("cornell", patches=300), solver="dispersive")
    engine.export_gltf(tmp_path / "box.gltf")
    (tmp_path / "box.bin").unlink()
    with pytest.raises(FileNotFoundError) as info:
        shrad.load(tmp_path / "box.gltf")
    assert "box.gltf" in str(info.value) and "box.bin" in str(info.value)


def test_missing_file_is_oserror_naming_it(tmp_path):
    missing = tmp_path / "nope.glb"
    with pytest.raises(OSError, match="nope.glb: cannot read file"):
        shrad.load(missing)
    with pytest.raises(OSError, match="not a built-in scene"):
        shrad.load("no_such_builtin")


def test_a_file_a_dict_names_that_is_missing_is_file_not_found(tmp_path):
    # The same error `load` gives for the file itself: an OSError naming the object and the
    # file, not a ValueError about the dict.
    scene = room_dict()
    scene["objects"].append({"name": "chair", "shape": "mesh", "file": str(tmp_path / "chair.obj")})
    with pytest.raises(FileNotFoundError, match=r"object 3 'chair'.*chair\.obj"):
        shrad.load_dict(scene)
    scene = room_dict()
    scene["environment"] = {"file": str(tmp_path / "sky.hdr")}
    with pytest.raises(FileNotFoundError, match=r"environment.*sky\.hdr"):
        shrad.load_dict(scene)
    e = shrad.Engine(shrad.load_dict(room_dict(patches=300)), solver="dispersive")
    with pytest.raises(FileNotFoundError, match=r"sky\.hdr"):
        e.set_sky(file=tmp_path / "sky.hdr")
    # A file that is there but wrong is still a ValueError.
    (tmp_path / "chair.obj").write_text("f 1 2 3\n")
    scene = room_dict()
    scene["objects"].append({"name": "chair", "shape": "mesh", "file": str(tmp_path / "chair.obj")})
    with pytest.raises(ValueError, match=r"chair\.obj") as info:
        shrad.load_dict(scene)
    assert not isinstance(info.value, OSError)


def test_bad_file_content_is_value_error_naming_it(tmp_path):
    bad = tmp_path / "broken.toml"
    bad.write_text("[[object]]\nshape = 'box'\nsize = [1, -1, 1]\n")
    with pytest.raises(ValueError, match="broken.toml"):
        shrad.load(bad)
    gltf = tmp_path / "broken.gltf"
    gltf.write_text("{ not json")
    with pytest.raises(ValueError, match="broken.gltf"):
        shrad.load(gltf)


def test_bad_steering_raises(cornell, tmp_path):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    with pytest.raises(ValueError, match="no object 'nope'.*short_block"):
        e.set_transform("nope", np.eye(4))
    with pytest.raises(ValueError, match="out of range"):
        e.set_emission(99, [1, 1, 1])
    with pytest.raises(ValueError, match="4x4"):
        e.set_transform(0, np.eye(3))
    singular = np.eye(4)
    singular[0, 0] = 0
    with pytest.raises(ValueError):
        e.set_transform(0, singular)
    with pytest.raises(ValueError):
        e.set_emission(0, [-1, 0, 0])
    with pytest.raises(ValueError, match="finite"):
        e.set_time(math.nan)
    with pytest.raises(ValueError, match="bands"):
        shrad.Engine(cornell, "dispersive", bands=9)
    with pytest.raises(ValueError, match="no solver 'magic'"):
        shrad.Engine(cornell, "magic")
    with pytest.raises(ValueError, match="no preset 'fancy'"):
        shrad.Engine(cornell, "grid", "fancy")
    with pytest.raises(ValueError, match="image size"):
        e.render(0, 10)
    with pytest.raises(ValueError, match="patches must be between"):
        shrad.load("cornell", patches=0)
    with pytest.raises(OSError, match="does not exist"):
        shrad.write_exr(tmp_path / "no" / "dir" / "x.exr", np.zeros((2, 2, 3), np.float32))
    # Nothing moved after all that.
    e.step()
    assert np.isfinite(e.radiosity).all()


def test_help_is_useful():
    doc = shrad.Engine.__doc__
    assert "set_transform" in doc and "radiosity" in doc
    assert "matrix" in shrad.Engine.set_transform.__doc__
    assert "(N, 3)" in shrad.Engine.radiosity.__doc__
    assert "patches" in shrad.load.__doc__


def test_a_gltf_with_nothing_to_light_loads_empty_and_runs(tmp_path):
    # A valid glTF whose one triangle has zero area (POSITION without bufferView: zeros)
    # loads empty, as a viewer opens it, saying why; the engine on it gives empty arrays and
    # a black picture, and refuses to bake it.
    p = tmp_path / "zeros.gltf"
    p.write_text(
        '{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],'
        ' "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],'
        ' "accessors": [{"componentType": 5126, "count": 3, "type": "VEC3",'
        ' "min": [0, 0, 0], "max": [0, 0, 0]}]}'
    )
    scene = shrad.load(p, patches=100)
    assert scene.objects == []
    assert any(w.startswith("nothing to light: every triangle") for w in scene.warnings), scene.warnings
    for solver in ["reference", "dispersive", "grid"]:
        e = shrad.Engine(scene, solver=solver)
        e.step()
        assert len(e) == 0
        for a in [e.radiosity, e.centres, e.normals, e.vertex_colors]:
            assert a.shape == (0, 3), solver
        assert e.areas.shape == (0,) and e.object_ids.shape == (0,)
        img = e.render(16, 8, spp=1)
        assert img.shape == (8, 16, 3) and not img.any(), solver
        with pytest.raises(ValueError, match="nothing to bake"):
            e.bake(tmp_path / "out.glb")
        with pytest.raises(ValueError, match="nothing to bake"):
            e.export_gltf(tmp_path / "out.glb")
    assert not (tmp_path / "out.glb").exists()


def test_a_dicts_reflectance_of_one_is_read_as_a_files_is():
    # A scene file's reflectance of 1 is read as 0.999 with a warning; the same dict was
    # refused ("must be in [0, 1)").
    d = room_dict()
    d["objects"][2]["reflectance"] = [1.0, 0.5, 0.5]
    scene = shrad.load_dict(d)
    assert any("clamped to" in w for w in scene.warnings), scene.warnings


def test_every_public_name_is_in_the_docs():
    """docs/python.md names every public function, class, method and attribute (a pass over
    the docs found a third of the Engine's and the Scene's only in their docstrings)."""
    import pathlib
    import re

    doc = (pathlib.Path(__file__).resolve().parents[3] / "docs" / "python.md").read_text()
    owners = [("shrad", shrad)] + [(c.__name__, c) for c in (shrad.Engine, shrad.Scene, shrad.ObjectInfo, shrad.ShotResult)]
    missing = [
        f"{owner}.{name}"
        for owner, obj in owners
        for name in dir(obj)
        if not name.startswith("_") and not re.search(r"[`.]" + re.escape(name) + r"\b", doc)
    ]
    assert not missing, f"not in docs/python.md: {missing}"
