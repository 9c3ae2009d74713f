"""Many independent shots on any ``concurrent.futures``-style executor.

A *shot* is one scene under one solver setting, stepped through its frames (a static
convergence, or a walk along the animation), optionally measured against the reference
and rendered from a camera. The shot is the unit of work because its frames depend on
each other; different shots do not, so they spread over processes or machines::

    shots = [shrad.Shot("cornell", patches=4000, settings={"cube_res": r}) for r in (16, 32, 64)]
    results = shrad.sweep(shots)                                    # in this process
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as ex:
        results = shrad.sweep(shots, executor=ex)                   # two processes
    results = shrad.sweep(shots, executor=dask.distributed.Client(cluster))   # a Dask cluster

A shot holds plain data only (a scene path, a built-in name or a ``load_dict`` dict, with
numpy meshes), so it pickles to any worker, which loads the scene itself. An executor is
anything with ``submit(fn, *args) -> future`` whose futures have ``result()``. Process pools
must *spawn* their workers (not fork): a forked child of a process that has solved
inherits a thread pool whose threads it does not have.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["Shot", "ShotResult", "ShotError", "run_shot", "sweep"]


@dataclasses.dataclass
class Shot:
    """One independent run: a scene, a solver and its settings, the frames to step, what to
    measure. ``scene`` is a path or built-in name (``shrad.load``) or a dict
    (``shrad.load_dict``). Frames: ``times`` steps one frame at each time of the scene's
    animation; else ``frames`` frames (default: until every object has been updated
    ``passes`` times). ``error_every=k`` records the error against the reference every k-th
    frame (and the last); ``error`` the final error; ``image=(width, height)`` renders the
    end state from ``camera`` (a dict as ``Engine.render`` takes, or the scene's)."""

    scene: str | Mapping[str, Any]
    name: str | None = None
    solver: str = "dispersive"
    preset: str = "default"
    settings: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    patches: int | None = None
    patch_size: float | None = None
    times: Sequence[float] | None = None
    frames: int | None = None
    passes: int = 2
    error: bool = True
    error_every: int = 0
    image: tuple[int, int] | None = None
    spp: int = 1
    camera: Mapping[str, Any] | None = None
    keep_radiosity: bool = True

    def label(self, index: int) -> str:
        """What a message calls this shot."""
        if self.name:
            return f"shot {index} '{self.name}'"
        scene = self.scene if isinstance(self.scene, str) else self.scene.get("name", "<dict>")
        extra = "".join(f" {k}={v}" for k, v in self.settings.items())
        return f"shot {index} ({scene}, {self.solver}/{self.preset}{extra})"


@dataclasses.dataclass
class ShotResult:
    """What a shot gives back: per-frame statistics, errors at the frames measured
    (``error_frames``, ``errors``: overall relative error), the final error dict, the final
    radiosity (N, 3) float32, the picture (H, W, 3) float32 when asked, and timings."""

    index: int
    name: str
    patches: int
    stats: list[dict[str, Any]]
    error_frames: list[int]
    errors: list[float]
    error: dict[str, float] | None
    radiosity: np.ndarray | None
    image: np.ndarray | None
    setup_s: float
    frames_s: float
    seconds: float

    @property
    def frame_ms(self) -> np.ndarray:
        """Each frame's time in milliseconds."""
        return np.array([s["frame_ms"] for s in self.stats])


class ShotError(RuntimeError):
    """A shot failed; the message names it and says why."""


def run_shot(shot: Shot, index: int = 0) -> ShotResult:
    """Run one shot here (what every worker of ``sweep`` calls)."""
    import shrad

    try:
        return _run(shrad, shot, index)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as e:  # named after the shot, whichever worker ran it; a Rust
        # panic (pyo3's PanicException, a BaseException) too, which some executors drop
        raise ShotError(f"{shot.label(index)}: {type(e).__name__}: {e}") from e


def _run(shrad, shot: Shot, index: int) -> ShotResult:
    t0 = time.perf_counter()
    if isinstance(shot.scene, Mapping):
        scene = shrad.load_dict(dict(shot.scene), patches=shot.patches, patch_size=shot.patch_size)
    else:
        scene = shrad.load(shot.scene, patches=shot.patches, patch_size=shot.patch_size)
    engine = shrad.Engine(scene, shot.solver, shot.preset, **dict(shot.settings))
    t1 = time.perf_counter()
    stats: list[dict[str, Any]] = []
    error_frames: list[int] = []
    errors: list[float] = []
    if shot.times is not None:
        steps = len(shot.times)
    elif shot.frames is not None:
        steps = shot.frames
    else:
        steps = engine.frames_to_converge(shot.passes)
    for i in range(steps):
        if shot.times is not None:
            engine.set_time(float(shot.times[i]))
        stats.append(engine.step())
        if shot.error_every and (i % shot.error_every == 0 or i == steps - 1):
            error_frames.append(i)
            errors.append(engine.error()["overall"])
    t2 = time.perf_counter()
    final = engine.error() if shot.error else None
    image = None
    if shot.image is not None:
        w, h = shot.image
        image = engine.render(w, h, spp=shot.spp, camera=None if shot.camera is None else dict(shot.camera))
    return ShotResult(
        index=index,
        name=shot.name or shot.label(index),
        patches=len(engine),
        stats=stats,
        error_frames=error_frames,
        errors=errors,
        error=final,
        radiosity=engine.radiosity if shot.keep_radiosity else None,
        image=image,
        setup_s=t1 - t0,
        frames_s=t2 - t1,
        seconds=time.perf_counter() - t0,
    )


def sweep(shots: Iterable[Shot], executor: Any = None, timeout: float | None = None) -> list[ShotResult]:
    """Run every shot, on ``executor`` (``submit(fn, *args)`` returning futures with
    ``result(timeout)``: a ``concurrent.futures`` pool, a Dask ``Client``, ...) or, when
    None, one after the other here. Results come back in the order of ``shots``. The first
    shot that fails raises ``ShotError`` naming it (the others are cancelled where the
    executor can); ``timeout`` bounds the wait for each result, in seconds."""
    shots = list(shots)
    for i, s in enumerate(shots):
        if not isinstance(s, Shot):
            raise TypeError(f"shot {i} is a {type(s).__name__}, not a shrad.Shot")
    if executor is None:
        return [run_shot(s, i) for i, s in enumerate(shots)]
    futures = [executor.submit(run_shot, s, i) for i, s in enumerate(shots)]
    results = []
    try:
        for i, f in enumerate(futures):
            try:
                results.append(f.result(timeout=timeout))
            except ShotError:
                raise
            except concurrent.futures.BrokenExecutor as e:
                # The pool, not the shot: its workers died or never started (it blamed the
                # shot it was waiting for).
                raise ShotError(
                    f"the executor broke while {shots[i].label(i)} waited: {type(e).__name__}: {e} "
                    "(a process pool that spawns its workers needs the script's work under "
                    'if __name__ == "__main__":)'
                ) from e
            except Exception as e:
                # A worker that died, a timeout, an exception the executor re-wrapped.
                raise ShotError(f"{shots[i].label(i)}: {type(e).__name__}: {e}") from e
    except BaseException:
        for f in futures:
            cancel = getattr(f, "cancel", None)
            if cancel is not None:
                cancel()
        raise
    return results
