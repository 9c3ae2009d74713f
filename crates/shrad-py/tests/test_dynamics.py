"""The engine while things change: a moved object, and the GIL released during solves."""

import threading
import time

import numpy as np

import shrad


def test_moving_an_object_raises_the_error_then_it_converges(cornell):
    e = shrad.Engine(cornell, solver="dispersive", preset="default")
    e.converge(passes=2)
    settled = e.error()["overall"]
    m = e.transform("short_block")
    m[:3, 3] += [0.0, 0.0, 200.0]  # across the floor, in the box's units (mm)
    e.set_transform("short_block", m)
    moved = e.error()["overall"]  # the light of the old pose on the new scene
    frames = []
    for _ in range(e.frames_to_converge(passes=2)):
        e.step()
        frames.append(e.error()["overall"])
    e.converge(passes=2)
    frames.append(e.error()["overall"])
    assert moved > 2.0 * settled, (settled, moved)
    assert frames[0] < moved  # the mover and its neighbours go first
    assert frames[-1] < 0.5 * moved and frames[-1] < 1.5 * settled, (settled, moved, frames)
    assert all(np.isfinite(frames))


def solving_span(engine, done):
    """Step `engine` (in the calling thread) and return the span of wall time in which its
    solve certainly ran in native code: the step's own span in Python, less at either end
    what Python added around the solve's `frame_ms` (the step minus the solve). Whatever
    another thread stamps inside it happened while the solve ran."""
    t0 = time.perf_counter()
    stats = engine.step()
    t1 = time.perf_counter()
    done.set()
    around = max(0.0, (t1 - t0) - stats["frame_ms"] / 1000)
    return t0 + around, t1 - around


def in_span(stamps, span):
    lo, hi = span
    return [s for s in stamps if lo < s[0] and s[-1] < hi]


# Counted in events, not timed (how long a solve takes, or how much two cores speed it up,
# is a measurement, not a test): with the GIL held through a solve, or the solves
# serialised below the bindings, no other thread could stamp anything inside the span, so
# these tests fail; released, the other thread stamps hundreds of times.
AT_LEAST = 3


def test_a_solve_lets_other_python_threads_run(cornell):
    """While one thread solves (GIL released), another runs Python: it comes back from
    short sleeps, each of which needs the GIL back, inside the solve's span."""
    e = shrad.Engine(cornell, solver="reference", preset="standard")
    done, span = threading.Event(), []
    t = threading.Thread(target=lambda: span.append(solving_span(e, done)))
    t.start()
    stamps = []
    while not done.is_set():
        time.sleep(0.001)
        stamps.append((time.perf_counter(),))
    t.join()
    inside = in_span(stamps, span[0])
    assert len(inside) >= AT_LEAST, f"{len(inside)} of {len(stamps)} rounds of Python ran inside the solve"


def test_two_engines_solve_at_once_in_two_threads():
    """Two engines in two Python threads solve at the same time: while one solves a large
    scene, the other begins and ends whole solves of a small one inside that solve's span.
    One worker thread per engine (threads=1), so nothing else shares them."""
    large = shrad.Engine(shrad.load("cornell", patches=2500), "reference", "standard", threads=1)
    small = shrad.Engine(shrad.load("cornell", patches=200), "reference", "fast", threads=1)
    small.step()  # its first solve builds what the next ones reuse
    done, span = threading.Event(), []
    t = threading.Thread(target=lambda: span.append(solving_span(large, done)))
    t.start()
    solves = []
    while not done.is_set():
        begun = time.perf_counter()
        small.step()
        solves.append((begun, time.perf_counter()))
    t.join()
    inside = in_span(solves, span[0])
    assert len(inside) >= AT_LEAST, f"{len(inside)} of {len(solves)} small solves ran inside the large one"
