#!/usr/bin/env bash
# Validate shrad against Mitsuba 3 on the Cornell box (slow: ~4 min on 2 cores; not part
# of the test suite). Creates validation/.venv, installs the pinned requirements, builds
# shrad, renders both and compares. Extra arguments go to mitsuba_cornell.py, e.g.
#   validation/run.sh --spp 256            # quicker, noisier reference
#   validation/run.sh --reuse-reference    # keep the cached Mitsuba image, re-run shrad
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
venv="$here/.venv"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -r "$here/requirements.txt"
cd "$root"
if ! cargo build --release -p shrad-cli; then
  echo "build failed; retrying without Embree (SHRAD_NO_EMBREE=1)" >&2
  SHRAD_NO_EMBREE=1 cargo build --release -p shrad-cli
fi
if [ ! -f "$root/scenes/cornell.obj" ]; then
  echo "scenes/cornell.obj missing" >&2
  exit 1
fi
exec "$venv/bin/python" "$here/mitsuba_cornell.py" --shrad "$root/target/release/shrad" "$@"
