# %% [markdown]
# # shrad from Python: a tour (notebook-style: each `# %%` is a cell)
#
# Run: `scripts/setup-python && target/py-venv/bin/python examples/python/tour.py [OUT_DIR]`
# (figures go to OUT_DIR, default docs/images/python). Figures: the bench's error against
# solver time, reproduced through `shrad.sweep`, and the error frame by frame while an
# object moves.

# %%
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import shrad

out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/images/python")
out.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## Error against solver time (the bench's figure, from Python)
# Each solver is one shot: built fresh on the static room, stepped, its error against the
# reference measured after every frame. `shrad.sweep` runs the shots (here in this process;
# pass `executor=` for a pool or a cluster).

# %%
patches = 6000
shots = [
    shrad.Shot("room", name="dispersive", patches=patches, frames=16, error_every=1),
    shrad.Shot("room", name="paper", patches=patches, preset="paper", frames=16, error_every=1),
    shrad.Shot("room", name="grid4", patches=patches, solver="grid", preset="paper4", frames=5, error_every=1),
    shrad.Shot("room", name="grid5", patches=patches, solver="grid", preset="paper5", frames=5, error_every=1),
]
results = shrad.sweep(shots)
fig, ax = plt.subplots(figsize=(7, 4.5))
for r in results:
    t = np.cumsum(r.frame_ms)[r.error_frames]
    ax.plot(t, 100 * np.array(r.errors), marker="s", ms=3, label=r.name)
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel("summed frame time (ms)")
ax.set_ylabel("relative L2 error (%)")
ax.set_title(f"Error against solver time, room ({results[0].patches} patches)")
ax.grid(True, which="both", alpha=0.3)
ax.legend()
fig.tight_layout()
fig.savefig(out / "error_vs_time.png", dpi=100)
for r in results:
    print(f"{r.name:10s} final error {100 * r.errors[-1]:5.1f} %  median frame {np.median(r.frame_ms):7.1f} ms")

# %% [markdown]
# ## An object moves: the error frame by frame
# The small box slides across the Cornell box's floor in 10 steps (one `set_transform` a
# frame, then two frames at rest at the end); after each frame, the error against a
# reference solve of the same state.

# %%
engine = shrad.Engine(shrad.load("cornell", patches=4000), solver="dispersive")
engine.converge(passes=2)
start = engine.transform("short_block")
errors = []
for i in range(16):
    if 1 <= i <= 10:
        m = start.copy()
        m[:3, 3] += [0.0, 0.0, 20.0 * i]
        engine.set_transform("short_block", m)
    engine.step()
    errors.append(100 * engine.error()["overall"])
fig, ax = plt.subplots(figsize=(7, 3.5))
ax.plot(range(len(errors)), errors, marker="o")
ax.axvspan(1, 10, alpha=0.1, label="moving")
ax.set_xlabel("frame")
ax.set_ylabel("relative L2 error (%)")
ax.set_title("Cornell box, short block moved 20 mm a frame")
ax.legend()
fig.tight_layout()
fig.savefig(out / "moving_error.png", dpi=100)
print("error per frame (%):", " ".join(f"{e:.1f}" for e in errors))

# %% [markdown]
# ## A picture and the bake
# %%
img = engine.render(256, 256, spp=4)
shrad.write_png(out / "cornell_after_move.png", img)
import tempfile

with tempfile.TemporaryDirectory() as tmp:
    print(engine.export_gltf(Path(tmp) / "cornell_baked.glb"))  # open it in three.js, Blender, Godot
