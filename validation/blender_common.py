"""What the Blender validation scripts share (run them with the bpy venv's python, see
docs/validation.md): a Cycles render set up for comparison with shrad (CPU, no denoising or
clamping, box filter, Standard view, linear EXR, a black world), reading and writing the
pictures, and docs/validation.md's metric (block-averaged relative RMSE of linear radiance).
Imported by blender_textures.py and blender_lights.py, which run from this folder."""
import time
from pathlib import Path

import bpy  # noqa: E402
import numpy as np  # noqa: E402


def black_world(sc) -> None:
    """A black world: Blender 5 gives a new world a node tree with a grey background."""
    sc.world = bpy.data.worlds.new("black")
    sc.world.color = (0.0, 0.0, 0.0)
    if sc.world.node_tree is not None:
        for n in sc.world.node_tree.nodes:
            if n.type == "BACKGROUND":
                n.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
                n.inputs["Strength"].default_value = 0.0


def render_cycles(out: Path, size: int, spp: int, seed: int = 0, name: str = "cycles") -> float:
    sc = bpy.context.scene
    sc.cycles.seed = seed
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = spp
    sc.cycles.use_denoising = False
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.max_bounces = 64
    sc.cycles.diffuse_bounces = 64
    sc.cycles.sample_clamp_direct = 0.0
    sc.cycles.sample_clamp_indirect = 0.0
    sc.cycles.pixel_filter_type = "BOX"
    sc.cycles.filter_width = 1.0
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    sc.render.resolution_x = sc.render.resolution_y = size
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.filepath = str(out / f"{name}.exr")
    black_world(sc)
    t0 = time.time()
    bpy.ops.render.render(write_still=True)
    return time.time() - t0


def read_exr(path: Path) -> np.ndarray:
    img = bpy.data.images.load(str(path))
    w, h = img.size
    a = np.array(img.pixels[:], dtype=np.float64).reshape(h, w, 4)[::-1, :, :3]
    bpy.data.images.remove(img)
    return a


def write_png(path: Path, rgb: np.ndarray, exposure: float) -> None:
    """Linear radiance times `exposure` -> sRGB PNG (clamped), top row first."""
    a = np.clip(rgb * exposure, 0.0, 1.0)
    s = np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1 / 2.4) - 0.055)
    h, w, _ = s.shape
    img = bpy.data.images.new(path.stem, w, h, alpha=False)
    img.colorspace_settings.name = "Non-Color"
    px = np.ones((h, w, 4), np.float32)
    px[..., :3] = s[::-1]
    img.pixels[:] = px.ravel()
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def blocks(img: np.ndarray, b: int) -> np.ndarray:
    h, w, c = img.shape
    return img[: h - h % b, : w - w % b].reshape(h // b, b, w // b, b, c).mean(axis=(1, 3))


def rel_rmse(a, ref, mask=None):
    if mask is not None:
        a, ref = a[mask], ref[mask]
    return float(np.sqrt(np.sum((a - ref) ** 2) / np.sum(ref ** 2)))
