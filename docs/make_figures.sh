#!/usr/bin/env bash
# Regenerates the figures and raw numbers behind docs/results.md (about 15 minutes on
# 2 cores). Usage: docs/make_figures.sh [reference|static|concave|moving|blender|timing|blotch|stability|all]
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
scripts/setup
cargo build --release --locked --bin shrad
S=target/release/shrad
F=docs/figures
mkdir -p "$F"

# Python with matplotlib for the plots, in a venv of its own.
if [ ! -x docs/.venv/bin/python ]; then
  python3 -m venv docs/.venv
  docs/.venv/bin/pip install -q -r docs/requirements.txt
fi
PY=docs/.venv/bin/python

errline() { sed -n 's/^error vs reference (spec 8): overall \(.*\) %, boundary \(.*\) %, interior \(.*\) %$/\1,\2,\3/p'; }

if [ "$what" = reference ] || [ "$what" = all ]; then
  # The reference solver's convergence, time and peak memory (GNU time's maximum RSS).
  for job in "cornell 20000" "room 100000"; do
    set -- $job
    /usr/bin/time -f "wall %e s, peak RSS %M KiB" $S render "$1" --patches "$2" \
      -o "$F/reference_$1_$2.png" --width 320 --height 320 --spp 4 > "$F/reference_$1_$2.txt" 2>&1
  done
fi

if [ "$what" = static ] || [ "$what" = all ]; then
  # Static scenes after convergence: reference, shrad default, --preset paper (same exposure).
  echo "scene,patches,solver,overall_pct,boundary_pct,interior_pct,last_frame_ms" > "$F/static_errors.csv"
  for scene in cornell scenes/cornell.gltf room; do
    name=$(basename "${scene%.*}")
    [ "$scene" = scenes/cornell.gltf ] && name=cornell_gltf
    log=$($S render "$scene" --patches 20000 -o "$F/${name}_reference.png" --width 320 --height 320 --spp 4 2>&1)
    exposure=$(echo "$log" | sed -n 's/^exposure //p')
    for preset in default paper; do
      out=$($S render "$scene" --patches 20000 --solver dispersive --preset $preset --compare \
        -o "$F/${name}_${preset}.png" --width 320 --height 320 --spp 4 --exposure "$exposure" 2>&1)
      ms=$(echo "$out" | sed -n 's/.*last frame \([0-9.]*\) ms.*/\1/p')
      echo "$scene,20000,$preset,$(echo "$out" | errline),$ms" >> "$F/static_errors.csv"
    done
    for g in 4 5; do
      out=$($S render "$scene" --patches 20000 --solver grid --set per_axis=$g --compare \
        -o "$F/${name}_grid$g.png" --width 320 --height 320 --spp 4 --exposure "$exposure" 2>&1)
      ms=$(echo "$out" | sed -n 's/.*last frame \([0-9.]*\) ms.*/\1/p')
      echo "$scene,20000,grid$g,$(echo "$out" | errline),$ms" >> "$F/static_errors.csv"
    done
  done
  # What each improvement of spec 4.6 is worth (Cornell box, 20k patches).
  echo "variant,overall_pct,boundary_pct,interior_pct" > "$F/ablation.csv"
  while IFS='|' read -r label flags; do
    # shellcheck disable=SC2086
    out=$($S render cornell --patches 20000 --solver dispersive --compare -q -o /tmp/shrad_ablation.png $flags 2>&1 < /dev/null)
    echo "$label,$(echo "$out" | errline)" >> "$F/ablation.csv"
  done <<'VARIANTS'
paper (all off)|--preset paper
+ probe margin and repair|--preset paper --set probe_margin=0.01 --set repair=move_inward
+ wall exchange|--preset paper --set probe_margin=0.01 --set repair=move_inward --set wall_exchange=true
+ see through self|--preset paper --set probe_margin=0.01 --set repair=move_inward --set wall_exchange=true --set see_through_self=true
+ direct on interior|--preset paper --set probe_margin=0.01 --set repair=move_inward --set wall_exchange=true --set see_through_self=true --set direct_on_interior=true
+ contact openness|--preset paper --set probe_margin=0.01 --set repair=move_inward --set wall_exchange=true --set see_through_self=true --set direct_on_interior=true --set contact_rays=8
+ emitter per face and gather (all on; R 128; round robin)|--preset paper --set probe_margin=0.01 --set repair=move_inward --set wall_exchange=true --set see_through_self=true --set direct_on_interior=true --set contact_rays=8 --set emitter_per_face=true --set to_boundary=auto
default (probes R 32, splat R 64; priority)|
default: repair drop|--set repair=drop
default: no repair|--set repair=none
default: no wall exchange|--set wall_exchange=false
default: own texels black|--set see_through_self=false
default: no near field (contact openness instead)|--set near_rays=0
default: no near field, no contact openness|--set near_rays=0 --set contact_rays=0
default: near reach 0.1|--set near_reach=0.1
default: near reach 0.5|--set near_reach=0.5
default: near rays 16|--set near_rays=16
default: repair move_inward (diagonal)|--set repair=move_inward
default: one emitter at the centre|--set emitter_per_face=false
default: splat|--set to_boundary=splat
default: splat without smoothing|--set to_boundary=splat --set splat_smoothing=false
default: 9 coefficients|--set bands=3
default: probes R 64|--set cube_res=64
default: probes R 128|--set cube_res=128
VARIANTS
fi

if [ "$what" = concave ] || [ "$what" = all ]; then
  # Self-occlusion on a concave object (an L-shaped block): see-through probes with the plain
  # cosine lobe, with transfer vectors, and the paper's black own texels.
  echo "variant,overall_pct,boundary_pct,interior_pct" > "$F/concave.csv"
  while IFS='|' read -r label flags; do
    # shellcheck disable=SC2086
    out=$($S render scenes/concave.toml --patches 10000 --solver dispersive --compare -q -o /tmp/shrad_concave.png $flags 2>&1 < /dev/null)
    echo "$label,$(echo "$out" | errline)" >> "$F/concave.csv"
  done <<'VARIANTS'
default (transfer vectors: 64 rays)|
default without transfer vectors|--set self_shadow_rays=0
default: own texels black instead of see-through|--set see_through_self=false --set self_shadow_rays=0
paper|--preset paper
VARIANTS
fi

if [ "$what" = moving ] || [ "$what" = all ]; then
  # A box sliding across the Cornell box floor over 120 frames, the light switching colour
  # half way: per-frame error for K = 1 round robin and for motion priority.
  $S animate scenes/moving_box.toml --solver dispersive --set schedule=round-robin --frames 120 --fps 30 \
    --error-every 2 --patches 10000 --rays-per-patch 128 --width 256 --height 256 -q -o /tmp/shrad_moving_single
  cp /tmp/shrad_moving_single/stats.csv "$F/moving_single_stats.csv"
  cp /tmp/shrad_moving_single/animation.gif "$F/moving_box.gif"
  # The same motion among four static objects, where the scheduler has a choice.
  for sched in round-robin priority; do
    $S animate scenes/moving_box_scene.toml --solver dispersive --set schedule=$sched --frames 120 --fps 30 \
      --error-every 2 --patches 10000 --rays-per-patch 128 --width 256 --height 256 -q -o "/tmp/shrad_moving_$sched"
    cp "/tmp/shrad_moving_$sched/stats.csv" "$F/moving_${sched}_stats.csv"
  done
  cp /tmp/shrad_moving_priority/animation.gif "$F/moving_box_scene.gif"
  $PY docs/plot.py moving "$F"
fi

if [ "$what" = blender ] || [ "$what" = all ]; then
  # The room animated in Blender and exported by Blender's glTF exporter (issue 10): played
  # whole (48 frames at 24 fps), the error against a reference solve of every frame.
  $S animate crates/shrad-scene/tests/data/blender/animated_room.glb --solver dispersive \
    --error-every 1 --patches 6000 --rays-per-patch 128 --width 256 --height 256 -q -o /tmp/shrad_blender_anim
  cp /tmp/shrad_blender_anim/stats.csv "$F/blender_animation_stats.csv"
  cp /tmp/shrad_blender_anim/animation.gif "$F/blender_animation.gif"
  $PY docs/plot.py blender "$F"
fi

if [ "$what" = timing ] || [ "$what" = all ]; then
  # Per-frame time of each step on a 75k-patch room (the paper's largest Table 3 row) and the
  # error after convergence, for the default and its cube-map resolutions.
  rm -f "$F"/timing_room75k_*.csv
  echo "tag,label,overall_pct,boundary_pct,interior_pct" > "$F/timing_room75k_errors.csv"
  while IFS='|' read -r tag label flags; do
    # shellcheck disable=SC2086
    $S animate room --patches 75000 --solver dispersive $flags --warmup 1 --frames 24 \
      --width 64 --height 64 -q -o "/tmp/shrad_timing_$tag" < /dev/null
    cp "/tmp/shrad_timing_$tag/stats.csv" "$F/timing_room75k_$tag.csv"
    # shellcheck disable=SC2086
    out=$($S render room --patches 75000 --solver dispersive $flags --compare -q \
      --width 64 --height 64 -o /tmp/shrad_timing.png 2>&1 < /dev/null)
    echo "$tag,$label,$(echo "$out" | errline)" >> "$F/timing_room75k_errors.csv"
  done <<'VARIANTS'
default|default: probes R 32; splat R 64 smoothed|
probes64|probes R 64|--set cube_res=64
raw|splat not smoothed|--set splat_smoothing=false
splat32|splat R 32|--set emitter_res=32
gather|gather instead of splat|--set to_boundary=gather
paperres|probes and emitters R 128 (gathers: 2 x 6 x 128^2 > boundary)|--set cube_res=128 --set emitter_res=128
VARIANTS
  $PY docs/plot.py timing "$F"
fi

if [ "$what" = stability ] || [ "$what" = all ]; then
  # Is the light stable in time (issue 22 item 3)? Settling after a stop, a still scene,
  # slow motion against the reference (room, 20k patches; about a minute).
  mkdir -p "$F/stability"
  cargo run --release --locked -p shrad --example stability -- 20000 "$F/stability" \
    | tee "$F/stability/summary.txt"
  $PY docs/plot.py stability "$F/stability"
fi

if [ "$what" = blotch ] || [ "$what" = all ]; then
  # Issue 22: the animated room at 20k patches, dispersive (without and with wall_smoothing)
  # beside the reference on the same patches (docs/results.md section 14).
  scene=crates/shrad-scene/tests/data/blender/animated_room.glb
  T=$(mktemp -d)
  $S render "$scene" --patches 20000 --solver reference -o "$T/ref.png" --quiet
  for v in false true; do
    $S render "$scene" --patches 20000 --solver dispersive --set wall_smoothing=$v \
      -o "$T/disp_$v.png" --quiet
  done
  $PY - "$T" docs/images <<'PY'
import sys
import matplotlib.image as mpimg
import numpy as np
t, out = sys.argv[1], sys.argv[2]
ref = mpimg.imread(f"{t}/ref.png")
gap = np.ones((ref.shape[0], 8, ref.shape[2]), ref.dtype)
for v, name in (("false", "before"), ("true", "after")):
    side = np.concatenate([mpimg.imread(f"{t}/disp_{v}.png"), gap, ref], axis=1)
    mpimg.imsave(f"{out}/animated_room_blotch_{name}.png", side)
PY
  rm -r "$T"
fi
