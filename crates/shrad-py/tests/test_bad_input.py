"""Bad input from a demanding user: each is a clear Python exception naming what is wrong,
never a panic, an abort in the allocator, or a call that cannot be stopped."""

import signal
import threading
import time

import numpy as np
import pytest

import shrad
from conftest import room_dict


def test_passes_are_bounded_not_an_abort(cornell, tmp_path):
    e = shrad.Engine(cornell, solver="dispersive")
    # converge(10**9) asked the allocator for 528 GB of frame statistics up front and
    # aborted the process; 2**62 was a PanicException (capacity overflow).
    for passes in [10**9, 2**62, -1]:
        with pytest.raises(ValueError, match=f"passes must be between 0 and 1000, got {passes}"):
            e.converge(passes)
        with pytest.raises(ValueError, match="passes must be between"):
            e.frames_to_converge(passes)
        with pytest.raises(ValueError, match="passes must be between"):
            e.bake(tmp_path / "out.glb", passes=passes)
    assert not (tmp_path / "out.glb").exists()
    assert e.frames == 0
    assert e.frames_to_converge(1000) == 1000 * e.frames_to_converge(1)


def test_a_sequences_frames_are_bounded_and_named(tmp_path):
    e = shrad.Engine(shrad.load_dict(room_dict(patches=600, keyframes=True)))
    # frames=10**12 asked the allocator for 4 TB of frame times and aborted the process;
    # -1 was pyo3's "can't convert negative int to unsigned", naming nothing.
    for frames in [10**12, 100_001, 0, -1]:
        with pytest.raises(ValueError, match=f"frames must be between 1 and 100000, got {frames}"):
            e.bake(tmp_path / "out.glb", frames=frames)
    assert list(tmp_path.iterdir()) == []


def test_error_is_nan_where_a_role_has_no_patches_and_finite_at_the_brightest(cornell):
    # A scene without interior objects: NaN, as documented (JSON made it None).
    walls = shrad.load_dict({"objects": [
        {"name": "room", "shape": "box", "size": [2, 2, 2], "inward": True,
         "role": "boundary", "reflectance": [0.5, 0.5, 0.5]},
        {"name": "lamp", "shape": "quad", "emission": [1, 1, 1],
         "corners": [[-0.2, 0.99, -0.2], [0.2, 0.99, -0.2], [0.2, 0.99, 0.2], [-0.2, 0.99, 0.2]]},
    ]}, patches=300)
    e = shrad.Engine(walls, solver="dispersive")
    e.step()
    err = e.error()
    assert isinstance(err["interior"], float) and np.isnan(err["interior"])
    assert np.isfinite(err["overall"])
    # The brightest emission a solve holds: the error's squares overflowed 32-bit floats.
    e = shrad.Engine(cornell, solver="dispersive")
    e.set_emission("light", [1e20] * 3)
    e.step()
    err = e.error()
    assert all(np.isfinite(err[k]) for k in ("overall", "boundary", "interior")), err


def test_a_png_of_a_picture_that_is_not_finite_is_refused(tmp_path):
    img = np.full((4, 4, 3), 0.5, np.float32)
    img[1, 2, 0] = np.inf
    # One infinite pixel made the exposure NaN and the whole PNG black, silently.
    for tonemap in ["exposure", "minmax"]:
        with pytest.raises(ValueError, match=r"pixel \(2, 1\) is \[inf"):
            shrad.write_png(tmp_path / "a.png", img, tonemap=tonemap)
    assert list(tmp_path.iterdir()) == []


class Interrupted(Exception):
    pass


def test_a_signal_stops_converge_between_frames(cornell):
    # Ctrl-C is SIGINT, whose handler raises KeyboardInterrupt: the library's converge loop
    # held every handler back until its last frame. Here SIGALRM's handler raises instead
    # (a KeyboardInterrupt that escaped would stop pytest), by the same path.
    e = shrad.Engine(cornell, solver="grid")  # a whole frame of probes each time
    t = time.perf_counter()
    e.step()
    frame = time.perf_counter() - t
    passes = 20

    def handler(*_):
        raise Interrupted

    old = signal.signal(signal.SIGALRM, handler)
    try:
        signal.setitimer(signal.ITIMER_REAL, 1.5 * frame)
        t = time.perf_counter()
        with pytest.raises(Interrupted):
            e.converge(passes)
        stopped = time.perf_counter() - t
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert 1 < e.frames < 1 + passes, e.frames
    assert stopped < 5 * frame + 1.0, (stopped, frame)
    # The engine is whole: a frame in progress ends before the handler runs.
    e.step()
    assert np.isfinite(e.radiosity).all()


def sigint_during(call, after):
    """`call()` while another thread sends SIGINT (what Ctrl-C sends) to this process `after`
    seconds in. Python runs the handler on the main thread, here raising Interrupted (a
    KeyboardInterrupt that escaped would stop pytest), as a library call that ends early
    at Ctrl-C raises KeyboardInterrupt. Returns (whether `call` raised Interrupted, seconds
    until it ended); a signal that lands after `call` returned raises here."""

    def handler(*_):
        raise Interrupted

    old = signal.signal(signal.SIGINT, handler)
    timer = threading.Timer(after, signal.pthread_kill, (threading.main_thread().ident, signal.SIGINT))
    try:
        timer.start()
        t = time.perf_counter()
        try:
            call()
            interrupted = False
        except Interrupted:
            interrupted = True
        took = time.perf_counter() - t
        timer.join()
    finally:
        try:
            timer.cancel()
        finally:
            signal.signal(signal.SIGINT, old)
    return interrupted, took


# The dispersive set-up of `large`: mostly its wall-exchange rows (60k patches x 128 rays),
# which stop between chunks; patching and the BVH before them (a tenth of it) do not.
LARGE = {"solver": "dispersive", "wall_rays": 128}


@pytest.fixture(scope="module")
def large():
    """A scene whose dispersive set-up and reference solve take a second or two each, the
    engine built without a signal and how long that took."""
    scene = shrad.load("cornell", patches=60000)
    t = time.perf_counter()
    engine = shrad.Engine(scene, **LARGE)
    return scene, engine, time.perf_counter() - t


def test_a_signal_stops_building_an_engine(large):
    # The set-up held Ctrl-C back until it had finished; now it stops within one object or
    # one chunk of wall rays, and no engine is made. (Stopped at a tenth of the whole, it
    # ends far before the whole would: a call that ran on would end after it.)
    scene, _, whole = large
    interrupted, took = sigint_during(lambda: shrad.Engine(scene, **LARGE), whole / 10)
    assert interrupted
    assert took < whole / 2, (took, whole)


def test_a_signal_stops_the_reference_solve_of_error(large):
    _, e, _ = large
    t = time.perf_counter()
    before = e.error()
    whole = time.perf_counter() - t
    interrupted, took = sigint_during(e.error, whole / 10)
    assert interrupted
    assert took < whole / 2, (took, whole)
    # The engine is whole.
    assert e.error() == before


def test_a_signal_stops_a_bake_before_any_file(cornell, tmp_path):
    # A thousand passes of the dispersive solver, its objects kept awake: seconds of frames
    # (2000 of about 1.5 ms).
    e = shrad.Engine(cornell, solver="dispersive", sleep_tolerance=0)
    passes = 1000
    path = tmp_path / "out.glb"
    interrupted, _ = sigint_during(lambda: e.bake(path, passes=passes), 0.2)
    assert interrupted
    # It stopped partway through its frames (a bake that ran on stepped them all and wrote
    # the file), and left no file, not even a staged one.
    assert e.frames < e.frames_to_converge(passes), e.frames
    assert list(tmp_path.iterdir()) == []
    # The engine is whole.
    e.step()
    assert np.isfinite(e.radiosity).all()


def test_converge_still_settles_the_dispersive_light(cornell):
    e = shrad.Engine(cornell, solver="dispersive")
    stats = e.converge(2)
    # Every object twice, then frames until the light settles (fewer than 256).
    assert e.frames_to_converge(2) < len(stats) < e.frames_to_converge(2) + 256
    assert [s["frame"] for s in stats] == list(range(len(stats)))
    before = e.radiosity
    e.step()
    np.testing.assert_allclose(e.radiosity.sum(), before.sum(), rtol=2e-4)


@pytest.mark.parametrize("write", [shrad.write_exr, shrad.write_png])
def test_a_picture_too_large_to_write_is_refused_before_it_is_copied(write, tmp_path):
    # A broadcast view costs numpy nothing; its copy (120 GB) aborted the process.
    huge = np.broadcast_to(np.zeros(3, np.float32), (100_000, 100_000, 3))
    path = tmp_path / "huge.exr"
    with pytest.raises(ValueError, match="100000x100000 pixels: a side may be at most 16384"):
        write(path, huge)
    assert not path.exists()


def test_objects_by_a_bad_index_or_type(cornell):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    n = len(cornell.objects)
    for bad in [-1, n, 2**70]:
        with pytest.raises(ValueError, match=f"object index {bad} out of range \\({n} objects\\)"):
            e.set_transform(bad, np.eye(4))
        with pytest.raises(ValueError, match=f"object index {bad} out of range"):
            e.transform(bad)
        with pytest.raises(ValueError, match=f"object index {bad} out of range"):
            e.set_emission(bad, [0, 0, 0])
    with pytest.raises(ValueError, match="light index -1 out of range \\(0 lights\\)"):
        e.set_light(-1)
    for bad in [1.0, None, True, [0]]:
        with pytest.raises(TypeError, match="an object is a name \\(str\\) or an index \\(int\\), got"):
            e.transform(bad)
    np.testing.assert_array_equal(e.transform(np.int64(1)), e.transform(1))


def test_render_sizes_and_cameras(cornell):
    e = shrad.Engine(cornell, solver="reference", preset="fast")
    with pytest.raises(ValueError, match="image size -1x10 with 4 samples per pixel: each must be at least 1"):
        e.render(-1, 10)
    with pytest.raises(ValueError, match="image size 8x8 with -2 samples"):
        e.render(8, 8, spp=-2)
    with pytest.raises(ValueError, match="image size 8589934592x8: a side may be at most 16384"):
        e.render(2**33, 8)
    cam = {"eye": [278, 273, -800], "target": [278, 273, 0]}
    for a in [0, -1, float("nan"), float("inf")]:
        with pytest.raises(ValueError, match="aspect_ratio .* must be a positive number"):
            e.render(8, 8, camera={**cam, "aspect_ratio": a})
    with pytest.raises(ValueError, match="camera 'yfov_deg' must be a number, got '40'"):
        e.render(8, 8, camera={**cam, "yfov_deg": "40"})
    assert e.render(8, 8, spp=1, camera={**cam, "aspect_ratio": 2.0}).shape == (8, 8, 3)


@pytest.mark.parametrize("solver", ["dispersive", "grid", "reference"])
def test_a_bad_budget_is_refused_by_every_solver(cornell, solver):
    # The dispersive solver refused these; the grid and the reference took them.
    e = shrad.Engine(cornell, solver=solver, preset="fast" if solver == "reference" else "default")
    for ms in [-1.0, 0.0, float("nan"), float("inf")]:
        with pytest.raises(ValueError, match="must be a positive number"):
            e.step(ms)
    assert e.frames == 0
    e.step(50.0)
    assert e.frames == 1


def test_numpy_scalars_are_numbers_as_settings(cornell):
    # A sweep over np.arange gives numpy scalars: they were "expected a number, got int64".
    e = shrad.Engine(cornell, "dispersive", cube_res=np.int64(8), probe_margin=np.float32(0.25), splat_smoothing=np.bool_(False))
    assert (e.option("cube_res"), e.option("splat_smoothing")) == ("8", "false")
    assert float(e.option("probe_margin")) == 0.25
    e.set_option("cube_res", np.uint16(16))
    assert e.option("cube_res") == "16"
    for bad in [np.complex64(1), [8], None]:
        with pytest.raises(ValueError, match="setting cube_res: expected a number, a bool or a string"):
            e.set_option("cube_res", bad)


OWN_POOL_TWO_THREADS = """
import threading, shrad
e = shrad.Engine(shrad.load("cornell", patches=1500), solver="grid", threads=2)
seen = []
readers = [threading.Timer(0.25 * k, lambda: seen.append(e.radiosity.shape)) for k in (1, 2)]
for r in readers:
    r.start()
for _ in range(4):
    e.step()
for r in readers:
    r.join()
assert len(seen) == len(readers), seen
print("ok", e.frames)
"""


def test_an_engine_with_its_own_threads_serves_two_python_threads():
    # A call waiting for the engine took the lock inside the engine's own pool, holding a
    # worker: with threads=2 the other thread's frame and the waiting call hung for good.
    # In a child process, so that a hang fails the test instead of stalling the suite.
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", OWN_POOL_TWO_THREADS], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0 and run.stdout.startswith("ok 4"), (run.stdout, run.stderr[-2000:])


def test_a_negative_count_is_a_value_error_naming_it(cornell):
    # As unsigned arguments these were pyo3's OverflowError ("can't convert negative int to
    # unsigned"), the argument named only in the exception's notes.
    with pytest.raises(ValueError, match="patches must be a positive count of patches, got -1"):
        shrad.load("cornell", patches=-1)
    with pytest.raises(ValueError, match="patches must be a positive count of patches, got -5"):
        cornell.with_patches(-5)
    with pytest.raises(ValueError, match="threads must be between 1 and 1024, got -1"):
        shrad.Engine(cornell, threads=-1)


def test_error_against_the_standard_reference_or_the_fast(cornell):
    # error() measures against the engine's reference (fast); reference="standard" is the
    # one `shrad render --compare` uses; another name is a ValueError naming the presets.
    e = shrad.Engine(cornell, solver="dispersive", preset="default")
    e.converge(1)
    own, fast, standard = e.error(), e.error(reference="fast"), e.error(reference="standard")
    assert own["overall"] == pytest.approx(fast["overall"], rel=1e-6)
    assert 0 < standard["overall"] < 0.2 and standard["overall"] != pytest.approx(fast["overall"], rel=1e-6)
    with pytest.raises(ValueError, match="reference 'best' is not a preset of the reference"):
        e.error(reference="best")


def test_patches_and_patch_size_together_are_refused():
    # patch_size won, silently, where the CLI refuses the two options together.
    with pytest.raises(ValueError, match="give patches or patch_size, not both"):
        shrad.load("cornell", patch_size=10, patches=100)
    with pytest.raises(ValueError, match="give patches or patch_size, not both"):
        shrad.load_dict(room_dict(patches=600), patches=100, patch_size=0.5)


@pytest.mark.parametrize("solver", ["dispersive", "grid", "reference"])
def test_a_block_squashed_all_but_flat_is_refused_not_an_abort(cornell, solver):
    # Squashed by 1e-16 along one axis, Embree aborted the interpreter (exit 134) at the
    # next step; shrunk whole by 1e-20, the BVH gave NaN.
    e = shrad.Engine(cornell, solver=solver)
    rest = e.transform("short_block")
    squashed = rest.copy()
    squashed[:3, 0] *= 1e-16
    with pytest.raises(ValueError, match="singular, or all but"):
        e.set_transform("short_block", squashed)
    tiny = rest.copy()
    tiny[:3, :3] *= 1e-20
    with pytest.raises(ValueError, match="world size would be"):
        e.set_transform("short_block", tiny)
    e.step()
    assert np.isfinite(e.radiosity).all()
