#!/usr/bin/env bash
# Sets the project up (scripts/setup.sh), then runs the whole test suite with the
# venv's pytest, the built ROS workspace sourced. Extra arguments go to pytest.
# Exit code: pytest's; a run that collected no test (pytest's 5) is a failure.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

PLOTTER_BROWSER=1 bash scripts/setup.sh

# colcon's setup scripts read unset variables: source them without -u.
set +u
# shellcheck disable=SC1091
source .venv/bin/activate
# shellcheck disable=SC1091
source ros_ws/install/setup.bash
set -u

# Tests marked `ros` fail (instead of being skipped) if the workspace is not usable.
export PLOTTER_REQUIRE_ROS=1

echo "[test] pytest tests/"
rc=0
python -m pytest tests/ -q --durations=25 "$@" || rc=$?
if [ "$rc" -eq 5 ]; then
    echo "[test] ERROR: pytest collected no tests" >&2
fi
exit "$rc"
