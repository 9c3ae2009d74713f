#!/usr/bin/env bash
# The static-errors table of docs/results.md section 2 (docs/make_figures.sh static, without
# the pictures): every solver after convergence at 20k patches, --compare against the
# reference (256 rays per patch).
set -euo pipefail
S=${S:-target/release/shrad}
OUT=${OUT:-/tmp/shrad_static}
mkdir -p "$OUT"
errline() { sed -n 's/^error vs reference (spec 8): overall \(.*\) %, boundary \(.*\) %, interior \(.*\) %$/\1,\2,\3/p'; }
echo "scene,patches,solver,overall_pct,boundary_pct,interior_pct,last_frame_ms" > "$OUT/static_errors.csv"
for scene in cornell scenes/cornell.gltf room; do
  for preset in default paper; do
    out=$($S render "$scene" --patches 20000 --solver dispersive --preset $preset --compare \
      -o "$OUT/x.png" --width 320 --height 320 --spp 4 2>&1)
    ms=$(echo "$out" | sed -n 's/.*last frame \([0-9.]*\) ms.*/\1/p')
    echo "$scene,20000,$preset,$(echo "$out" | errline),$ms" >> "$OUT/static_errors.csv"
  done
  for g in 4 5; do
    out=$($S render "$scene" --patches 20000 --solver grid --grid $g --compare \
      -o "$OUT/x.png" --width 320 --height 320 --spp 4 2>&1)
    ms=$(echo "$out" | sed -n 's/.*last frame \([0-9.]*\) ms.*/\1/p')
    echo "$scene,20000,grid$g,$(echo "$out" | errline),$ms" >> "$OUT/static_errors.csv"
  done
done
cat "$OUT/static_errors.csv"
