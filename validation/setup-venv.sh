#!/usr/bin/env bash
# The Mitsuba 3 venv for the validation scripts, under target/ (pinned: validation/requirements.txt).
# Prints the venv's python.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/target/validation-venv"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv" >&2
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -r "$root/validation/requirements.txt" >&2
echo "$venv/bin/python"
