#!/usr/bin/env bash
# The main job: set everything up, then draw the reference board's figures on
# the mock board through the whole node graph and write docs/demo.svg.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
set +u
source .venv/bin/activate
source ros_ws/install/setup.bash
set -u
exec python scripts/demo.py "$@"
