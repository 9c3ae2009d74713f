"""Type stubs of the native module ``shrad._shrad`` (PyO3)."""

import os
from typing import Any, Literal, Mapping, Sequence, TypedDict

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = str | os.PathLike[str]
ArrayLike = npt.ArrayLike
ObjRef = int | str
SolverName = Literal["dispersive", "grid", "reference"]

class CameraDict(TypedDict, total=False):
    eye: Sequence[float]
    target: Sequence[float]
    yfov_deg: float
    aspect_ratio: float

class ErrorDict(TypedDict):
    overall: float
    boundary: float
    interior: float

class ObjectInfo:
    """One object of a scene: name, role, world bounds at rest, triangles, animated."""

    index: int
    name: str
    role: Literal["boundary", "interior", "light"]
    bounds: tuple[tuple[float, float, float], tuple[float, float, float]]
    triangles: int
    animated: bool

class Scene:
    """A loaded scene and how it is to be cut into patches (immutable)."""

    @property
    def source(self) -> str: ...
    @property
    def objects(self) -> list[ObjectInfo]: ...
    @property
    def bounds(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...
    @property
    def duration(self) -> float: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def patching(self) -> tuple[Literal["count", "size"], float]: ...
    def with_patches(self, patches: int | None = None, patch_size: float | None = None) -> Scene: ...
    def __len__(self) -> int: ...

class Engine:
    """The live engine over one scene: a patched world and one solver."""

    def __init__(
        self,
        scene: Scene,
        solver: SolverName = "dispersive",
        preset: str = "default",
        *,
        backend: Literal["auto", "embree", "bvh"] = "auto",
        threads: int | None = None,
        **settings: int | float | bool | str,
    ) -> None: ...
    @property
    def solver(self) -> SolverName: ...
    @property
    def settings(self) -> list[tuple[str, str]]: ...
    def set_option(self, key: str, value: int | float | bool | str) -> float | None: ...
    def option(self, key: str) -> str: ...
    def set_solver(self, solver: SolverName, preset: str = "default", **settings: int | float | bool | str) -> float: ...
    def set_transform(self, obj: ObjRef, matrix: ArrayLike) -> None: ...
    def transform(self, obj: ObjRef) -> npt.NDArray[np.float64]: ...
    def set_emission(self, obj: ObjRef, rgb: Sequence[float]) -> None: ...
    def set_reflectance(self, obj: ObjRef, rgb: Sequence[float]) -> None: ...
    def set_sky(
        self,
        radiance: Sequence[float] | None = None,
        file: str | None = None,
        rotate_deg: float = 0.0,
        scale: float = 1.0,
    ) -> None: ...
    def set_light(
        self,
        light: ObjRef,
        matrix: Any | None = None,
        rgb: Sequence[float] | None = None,
        intensity: float | None = None,
    ) -> None: ...
    def set_time(self, t: float) -> None: ...
    @property
    def time(self) -> float: ...
    def step(self, budget_ms: float | None = None) -> dict[str, Any]: ...
    def frames_to_converge(self, passes: int = 2) -> int: ...
    def converge(self, passes: int = 2) -> list[dict[str, Any]]: ...
    @property
    def frames(self) -> int: ...
    def __len__(self) -> int: ...
    @property
    def radiosity(self) -> npt.NDArray[np.float32]: ...
    @property
    def vertex_colors(self) -> npt.NDArray[np.float32]: ...
    @property
    def centres(self) -> npt.NDArray[np.float32]: ...
    @property
    def normals(self) -> npt.NDArray[np.float32]: ...
    @property
    def areas(self) -> npt.NDArray[np.float32]: ...
    @property
    def object_ids(self) -> npt.NDArray[np.uint32]: ...
    @property
    def reflectance(self) -> npt.NDArray[np.float32]: ...
    @property
    def objects(self) -> list[ObjectInfo]: ...
    def render(
        self,
        width: int = 512,
        height: int = 512,
        *,
        spp: int = 4,
        camera: CameraDict | None = None,
        shading: Literal["smooth", "flat"] = "smooth",
    ) -> npt.NDArray[np.float32]: ...
    def error(self, *, reference: str | None = None) -> ErrorDict: ...
    def probes(self) -> dict[str, Any]: ...
    def export_probes(self, path: PathLike) -> dict[str, Any]: ...
    def export_gltf(self, path: PathLike, *, exposure: float | None = None) -> dict[str, Any]: ...
    def bake(
        self,
        path: PathLike,
        *,
        time: float | None = None,
        frames: int | None = None,
        passes: int = 2,
        exposure: float | None = None,
        lightmap: bool = False,
        texel_size: float | None = None,
        lightmap_res: int | None = None,
        lightmap_format: str | None = None,
    ) -> list[dict[str, Any]]: ...

def load(
    path: PathLike,
    *,
    patches: int | None = None,
    patch_size: float | None = None,
    animation: str | None = None,
    drop_degenerate: bool = False,
) -> Scene: ...
def load_dict(
    definition: Mapping[str, Any], *, patches: int | None = None, patch_size: float | None = None
) -> Scene: ...
def builtins() -> list[str]: ...
def options(solver: SolverName | None = None) -> list[dict[str, Any]]: ...
def write_exr(path: PathLike, image: ArrayLike) -> None: ...
def write_png(
    path: PathLike,
    image: ArrayLike,
    *,
    exposure: float | None = None,
    tonemap: Literal["exposure", "minmax"] = "exposure",
) -> None: ...
def read_exr(path: PathLike) -> npt.NDArray[np.float32]: ...
