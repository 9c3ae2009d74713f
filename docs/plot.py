"""Plots for docs/results.md from the CSV files docs/make_figures.sh writes."""
import csv
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def moving(folder):
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for name, label in [
        ("single", "box alone, K = 1"),
        ("round-robin", "box + 4 objects, round robin K = 1"),
        ("priority", "box + 4 objects, motion priority K = 1"),
    ]:
        r = [x for x in rows(f"{folder}/moving_{name}_stats.csv") if x["error"]]
        ax.plot([int(x["frame"]) for x in r], [100 * float(x["error"]) for x in r], label=label)
    ax.axvline(60, color="grey", ls=":", lw=1)
    ax.text(61, ax.get_ylim()[1] * 0.9, "light changes colour", fontsize=8, color="grey")
    ax.set_xlabel("frame (30 fps; the box slides for 120 frames)")
    ax.set_ylabel("error vs reference (%)")
    ax.set_title("Moving box in the Cornell box: per-frame error (spec 8)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(f"{folder}/moving_error.png", dpi=110)


def blender(folder):
    r = [x for x in rows(f"{folder}/blender_animation_stats.csv") if x["error"]]
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.plot([int(x["frame"]) for x in r], [100 * float(x["error"]) for x in r], label="dispersive default, K = 1")
    ax.set_xlabel("frame (shrad animate at its default 30 fps; the animation lasts 1.96 s)")
    ax.set_ylabel("error vs reference (%)")
    ax.set_title("Room animated in Blender, exported by Blender: per-frame error (spec 8)")
    ax.set_ylim(bottom=0)
    ax.legend()
    fig.tight_layout()
    fig.savefig(f"{folder}/blender_animation_error.png", dpi=110)


def timing(folder):
    keys = ("direct_ms", "objects_ms", "to_boundary_ms", "assemble_ms", "frame_ms")
    with open(f"{folder}/timing_room75k.md", "w") as f:
        f.write(
            "| variant | Step 1 direct (ms) | Step 2 objects (ms) | Step 3 to boundary (ms) "
            "| Step 4 assemble (ms) | frame (ms) | error overall / boundary / interior |\n"
            "|---|---:|---:|---:|---:|---:|---|\n"
        )
        for v in rows(f"{folder}/timing_room75k_errors.csv"):
            # Frames after the first pass over the 8 objects.
            r = rows(f"{folder}/timing_room75k_{v['tag']}.csv")[4:]
            m = {k: statistics.median(float(x[k]) for x in r) for k in keys}
            f.write(
                f"| {v['label']} | {m['direct_ms']:.1f} | {m['objects_ms']:.1f} "
                f"| {m['to_boundary_ms']:.1f} | {m['assemble_ms']:.1f} | {m['frame_ms']:.1f} "
                f"| {v['overall_pct']} / {v['boundary_pct']} / {v['interior_pct']} % |\n"
            )


def stability(folder):
    """The three runs of `examples/stability.rs`: settling after a stop, a still scene, and
    slow motion's far-wall change against the reference's."""
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.4))
    r = rows(f"{folder}/settling.csv")
    frames = [int(x["frame_after_stop"]) for x in r]
    for key, label in [("overall_pct", "overall"), ("boundary_pct", "boundary"), ("interior_pct", "interior")]:
        axes[0].plot(frames, [float(x[key]) for x in r], label=label)
    axes[0].set_xlabel("frames after the object stops")
    axes[0].set_ylabel("error vs reference of the stopped state (%)")
    axes[0].set_title("Settling after a stop")
    axes[0].legend(fontsize=8)
    r = rows(f"{folder}/still.csv")
    for sleep, label in [("true", "sleep on (default)"), ("false", "sleep off")]:
        s = [x for x in r if x["sleep"] == sleep]
        axes[1].plot([int(x["frame"]) for x in s], [float(x["largest_patch_change_pct"]) for x in s], label=label)
    axes[1].set_xlabel("frame, converged scene left still")
    axes[1].set_ylabel("largest patch change since the frame before (%)")
    axes[1].set_title("A still scene")
    axes[1].legend(fontsize=8)
    r = rows(f"{folder}/slow.csv")
    f = [int(x["frame"]) for x in r]
    axes[2].plot(f, [float(x["dispersive_far_change_pct"]) for x in r], label="dispersive default")
    axes[2].plot(f, [float(x["reference_far_change_pct"]) for x in r], label="reference, same states")
    axes[2].set_xlabel("frame, object moving 0.25 % of the room a frame")
    axes[2].set_ylabel("far walls' change since the frame before (%)")
    axes[2].set_title("Slow motion: flicker far away")
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(f"{folder}/stability.png", dpi=100)


if __name__ == "__main__":
    {"moving": moving, "blender": blender, "timing": timing, "stability": stability}[sys.argv[1]](
        sys.argv[2]
    )
