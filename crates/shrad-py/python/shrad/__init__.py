"""shrad: global illumination (diffuse interreflection) for dynamic scenes.

The dispersive spherical-harmonics method of Wang, Liu & Wu (2007), the paper's probe-grid
baseline and a converged reference radiosity solver, over one live engine::

    import shrad
    scene = shrad.load("cornell", patches=8000)        # a file or a built-in name
    engine = shrad.Engine(scene, solver="dispersive", preset="default")
    stats = engine.step()                               # one frame, GIL released
    B = engine.radiosity                                # (N, 3) float32
    img = engine.render(400, 400, spp=4)                # (H, W, 3) float32, linear
    shrad.write_exr("cornell.exr", img)
    print(engine.error()["overall"])                    # against a reference solve

``shrad.load_dict`` builds a scene from a dict (numpy meshes), ``Engine.export_gltf``
bakes the light into a glTF for other engines, ``shrad.sweep`` runs many independent
shots on any ``concurrent.futures``-style executor (a process pool, Dask, Ray).
"""

from ._shrad import (
    Engine,
    ObjectInfo,
    Scene,
    __version__,
    builtins,
    load,
    load_dict,
    options,
    read_exr,
    write_exr,
    write_png,
)
from .sweep import Shot, ShotError, ShotResult, run_shot, sweep

__all__ = [
    "Engine",
    "ObjectInfo",
    "Scene",
    "Shot",
    "ShotError",
    "ShotResult",
    "__version__",
    "builtins",
    "load",
    "load_dict",
    "options",
    "presets",
    "read_exr",
    "run_shot",
    "sweep",
    "write_exr",
    "write_png",
]


def presets(solver: str) -> list[str]:
    """The presets of ``solver``, its default first (from ``shrad.options``)."""
    table = options(solver)
    return list(table[0]["defaults"]) if table else []
