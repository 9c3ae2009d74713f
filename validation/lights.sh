#!/usr/bin/env bash
# shrad's lights and sky against Mitsuba 3 (docs/validation.md, "Lights and sky"): sets up
# the venv under target/ (validation/setup-venv.sh), builds shrad, runs mitsuba_lights.py.
# Extra arguments go to the script, e.g. validation/lights.sh --spp 128 --cases point,envmap
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
python="$("$root/validation/setup-venv.sh")"
cd "$root"
cargo build --release -p shrad-cli
exec "$python" "$root/validation/mitsuba_lights.py" --shrad "$root/target/release/shrad" "$@"
