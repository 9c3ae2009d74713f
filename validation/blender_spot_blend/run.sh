#!/usr/bin/env bash
# Blender's spot lamps against Cycles (docs/results.md §6, "An eighth pass"): for each spot
# (size, blend), build the room in Blender, export it with Blender's glTF exporter, render it
# with Cycles (full light, and direct light only with black walls), render the exported file
# with shrad's reference, and print shrad / Cycles (mean and across the cone's edge).
#
#   python3.11 -m venv /tmp/bpyenv && /tmp/bpyenv/bin/pip install bpy==5.0.1 numpy OpenEXR
#   BPY=/tmp/bpyenv/bin/python validation/blender_spot_blend/run.sh [SHRAD]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
shrad="${1:-$root/target/release/shrad}"
py="${BPY:-/tmp/bpyenv/bin/python}"
out="${OUT:-$root/target/blender-spot-blend}"
mkdir -p "$out"
for v in "90 0.3" "90 0.0" "90 1.0" "60 0.3"; do
  set -- $v
  n="$out/v$1_b$2"
  "$py" "$here/build.py" "$n/full" --size "$1" --blend "$2" --walls 0.6 --spp 1024 --bounces 32
  "$py" "$here/build.py" "$n/direct" --size "$1" --blend "$2" --walls 0.0 --spp 256 --bounces 0
  for k in full direct; do
    (cd "$n/$k" && "$shrad" render scene.glb --hdr shrad_after.exr -o shrad_after.png --width 320 \
      --height 240 --patches 20000 --solver reference --spp 16 -q)
  done
  "$py" "$here/compare.py" "$n" --tags after
done
