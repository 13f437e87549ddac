#!/usr/bin/env bash
# Sets the project up (scripts/setup.sh), then runs the whole test suite with the
# venv's pytest, the built ROS workspace sourced, in the stages of
# scripts/test_stages.py (docs/testing.md): its last line gives the counts and
# the time, set-up included. Extra arguments go to pytest (e.g. a test file, -k).
# Exit code: 0 when every stage passed; a run that collected no test is a failure.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
START_TIME="$(date +%s)"

PLOTTER_BROWSER=1 bash scripts/setup.sh

# colcon's setup scripts read unset variables: source them without -u.
set +u
# shellcheck disable=SC1091
source .venv/bin/activate
# shellcheck disable=SC1091
source ros_ws/install/setup.bash
set -u

# Nothing is skipped in silence: tests marked `ros` fail (instead of being
# skipped) if the workspace is not usable, the LinuxCNC oracle (fetched from
# Debian's archive) must run, and a skip for any reason but those
# tests/conftest.py expects is a failure.
export PLOTTER_REQUIRE_ROS=1 PLOTTER_REQUIRE_RS274=1 PLOTTER_STRICT_SKIPS=1
export PLOTTER_TEST_START="${PLOTTER_TEST_START:-$START_TIME}"

exec python scripts/test_stages.py "$@"
