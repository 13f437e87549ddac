#!/usr/bin/env bash
# Installs everything the plotter project needs to build and test, on a Debian 12
# machine (run as root, or as a user with sudo for the apt step):
#   - Debian packages: sdcc + sdcc-ucsim (8051 compiler and simulator), what
#     the Python venv needs (python3-venv, python3-dev, g++) when missing, and
#     with PLOTTER_BROWSER=1 chromium and chromium-driver (the web page's tests);
#   - the venv .venv/ with ROS 2 Jazzy (PyPI wheels), colcon and the test tools,
#     pinned in requirements.txt / requirements-build.txt;
#   - a fix for the message wheels' exported CMake files (they name the wheel
#     builder's include paths);
#   - the colcon workspace ros_ws/ built into ros_ws/install/;
#   - the `plotter` command in .venv/bin/;
#   - the firmware (make -C firmware), and the host libraries of its Z axis and line-following builds
#     (ZAXIS=1, FOLLOW=1), when firmware/Makefile exists.
# Idempotent: each step is skipped when its inputs did not change.
# Environment: PYTHON (default python3) is the interpreter the venv is made from.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
VENV="$ROOT/.venv"
WS="$ROOT/ros_ws"
PYTHON="${PYTHON:-python3}"
UV_VERSION=0.13.9
# One set-up at a time in this tree (several people or test runs may start it at once).
exec 9<"${BASH_SOURCE[0]}"
flock 9
START=$SECONDS

log() { printf '[setup %3ds] %s\n' "$((SECONDS - START))" "$*"; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }

hash_files() { cat "$@" | sha256sum | cut -d' ' -f1; }

# --- 1. Debian packages -------------------------------------------------------
command -v "$PYTHON" >/dev/null || die "$PYTHON not found (set PYTHON=/path/to/python3.11)"
apt_pkgs=()
command -v sdcc >/dev/null || apt_pkgs+=(sdcc)
command -v s51 >/dev/null || apt_pkgs+=(sdcc-ucsim)
command -v c++ >/dev/null || apt_pkgs+=(g++)
# The web page's tests drive Debian's chromium (scripts/test.sh asks for it).
if [ "${PLOTTER_BROWSER:-0}" = 1 ]; then
    command -v chromium >/dev/null || apt_pkgs+=(chromium)
    command -v chromedriver >/dev/null || apt_pkgs+=(chromium-driver)
fi
if [ ! -x "$VENV/bin/python" ]; then
    # Debian's python3 needs python3-venv for ensurepip, and python3-dev for the
    # headers the rosidl Python extensions are compiled against.
    "$PYTHON" -c 'import ensurepip' 2>/dev/null || apt_pkgs+=(python3-venv)
fi
"$PYTHON" -c 'import os, sysconfig, sys; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
    || apt_pkgs+=(python3-dev)
if [ ${#apt_pkgs[@]} -gt 0 ]; then
    SUDO=()
    [ "$(id -u)" -eq 0 ] || SUDO=(sudo)
    log "apt-get install ${apt_pkgs[*]}"
    export DEBIAN_FRONTEND=noninteractive
    "${SUDO[@]}" apt-get update -qq
    "${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${apt_pkgs[@]}" >/dev/null
fi
log "toolchain: $(sdcc --version 2>&1 | head -1 | cut -c1-60)"

# --- 2. venv and Python packages -----------------------------------------------
# A venv whose making was interrupted has a python but no pip: make it again.
if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -m pip --version >/dev/null 2>&1; then
    log "creating venv $VENV from $("$PYTHON" --version 2>&1)"
    "$PYTHON" -m venv --clear "$VENV"
fi
PY="$VENV/bin/python"
PYVER="$("$PY" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')"
[ "$PYVER" = "3.11" ] || die "the ROS 2 Jazzy wheels need Python 3.11; the venv has $PYVER (rm -rf .venv; PYTHON=python3.11 $0)"

REQ_STAMP="$VENV/.plotter-requirements.sha256"
req_hash="$(hash_files requirements.txt requirements-build.txt)"
if [ "$(cat "$REQ_STAMP" 2>/dev/null)" != "$req_hash" ]; then
    # uv fetches and unpacks the ~190 wheels side by side (8 s where pip took
    # 100 s on a fresh machine); pip when uv cannot be had.
    if "$PY" -m pip install -q --disable-pip-version-check "uv==$UV_VERSION" 2>/dev/null; then
        log "uv pip install -r requirements-build.txt (ROS 2 Jazzy wheels, colcon, pytest)"
        "$VENV/bin/uv" pip install -q --python "$PY" -r requirements-build.txt
    else
        log "pip install -r requirements-build.txt (ROS 2 Jazzy wheels, colcon, pytest)"
        "$PY" -m pip install -q --disable-pip-version-check -r requirements-build.txt
    fi
    echo "$req_hash" > "$REQ_STAMP"
else
    log "Python packages up to date"
fi

# --- 3. Fix the include paths in the wheels' exported CMake files ---------------
# The message wheels were built in /opt/python/cp311-cp311; their CMake targets
# name that interpreter's include dirs, which do not exist here.
PY_INC="$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
NP_INC="$("$PY" -c 'import numpy; print(numpy.get_include())')"
BAD_PY_INC=/opt/python/cp311-cp311/include/python3.11
BAD_NP_INC=/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include
mapfile -t bad_files < <(grep -rlF --include='*.cmake' -e "$BAD_PY_INC" -e "$BAD_NP_INC" "$VENV/share" || true)
if [ ${#bad_files[@]} -gt 0 ]; then
    log "patching ${#bad_files[@]} CMake files of the wheels (Python and numpy include dirs)"
    sed -i -e "s|$BAD_PY_INC|$PY_INC|g" -e "s|$BAD_NP_INC|$NP_INC|g" "${bad_files[@]}"
fi

# --- 4. colcon workspace -----------------------------------------------------------
# The venv is laid out like a ROS install prefix. local_setup.{sh,bash} in it
# lets the workspace's setup.bash chain to it (colcon records the prefixes in
# COLCON_PREFIX_PATH at build time), so that sourcing ros_ws/install/setup.bash
# also puts the venv on AMENT_PREFIX_PATH / CMAKE_PREFIX_PATH.
cat > "$VENV/local_setup.sh" <<EOF
# Generated by scripts/setup.sh: the venv as a ROS prefix (chained by ros_ws/install/setup.*).
case ":\${AMENT_PREFIX_PATH:-}:" in *":$VENV:"*) ;; *) export AMENT_PREFIX_PATH="$VENV\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}" ;; esac
case ":\${CMAKE_PREFIX_PATH:-}:" in *":$VENV:"*) ;; *) export CMAKE_PREFIX_PATH="$VENV\${CMAKE_PREFIX_PATH:+:\$CMAKE_PREFIX_PATH}" ;; esac
case ":\${PATH:-}:" in *":$VENV/bin:"*) ;; *) export PATH="$VENV/bin\${PATH:+:\$PATH}" ;; esac
EOF
printf '# Generated by scripts/setup.sh.\n. "%s/local_setup.sh"\n' "$VENV" > "$VENV/local_setup.bash"

BUILD_STAMP="$WS/install/.plotter-build.sha256"
src_hash="$( { echo "$req_hash"; cd "$WS/src" && find . -type f ! -path '*/__pycache__/*' ! -name '*.pyc' ! -path '*.egg-info/*' -print0 \
    | LC_ALL=C sort -z | xargs -0 sha256sum; } | sha256sum | cut -d' ' -f1)"
if [ ! -f "$WS/install/setup.bash" ] || [ "$(cat "$BUILD_STAMP" 2>/dev/null)" != "$src_hash" ]; then
    log "colcon build in ros_ws/ (plotter_interfaces, plotter_bridge, plotter_shapes, plotter_web)"
    (
        cd "$WS"
        # setup.py install never deletes modules that left the source tree: start
        # the (quick) Python packages afresh so the install matches src/.
        for setup_py in src/*/setup.py; do
            [ -f "$setup_py" ] || continue
            pkg="$(basename "$(dirname "$setup_py")")"
            rm -rf "build/$pkg" "install/$pkg"
        done
        export PATH="$VENV/bin:$PATH" VIRTUAL_ENV="$VENV"
        export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV" COLCON_PREFIX_PATH="$VENV"
        unset PYTHONPATH PYTHONDONTWRITEBYTECODE
        # colcon's own make flags add -l<cores>: with the machine's load at its
        # core count (this build, a test run beside it) make then ran one job.
        export MAKEFLAGS="-j$(nproc)"
        "$VENV/bin/colcon" --log-base log build \
            --base-paths src --build-base build --install-base install \
            --event-handlers console_cohesion- console_start_end- console_package_list- summary+ status- \
            --cmake-args -DPython3_EXECUTABLE="$PY" -DBUILD_TESTING=OFF \
            || { echo "colcon build failed; logs in ros_ws/log/latest_build/" >&2; exit 1; }
    )
    echo "$src_hash" > "$BUILD_STAMP"
else
    log "ros_ws/install up to date"
fi

# --- 5. The `plotter` command -------------------------------------------------------
# Runs plotter_bridge.cli.main:main with the venv's Python and the workspace's
# packages on the paths, without sourcing anything (works from any shell).
cat > "$VENV/bin/plotter" <<EOF
#!/usr/bin/env bash
# plotter: command-line tool of the pen plotter (plotter_bridge.cli.main:main).
# Generated by scripts/setup.sh; puts the built workspace $WS/install on the paths.
set -e
venv="$VENV"
ament="\$venv" pypath="" ldpath=""
for p in "$WS"/install/*/; do
    p="\${p%/}"
    [ -d "\$p/share" ] || continue
    ament="\$p:\$ament"
    [ -d "\$p/lib/python$PYVER/site-packages" ] && pypath="\$p/lib/python$PYVER/site-packages:\$pypath"
    [ -d "\$p/lib" ] && ldpath="\$p/lib:\$ldpath"
done
export AMENT_PREFIX_PATH="\$ament\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}"
export PYTHONPATH="\${pypath%:}\${PYTHONPATH:+:\$PYTHONPATH}"
export LD_LIBRARY_PATH="\${ldpath%:}\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
export PATH="\$venv/bin:\$PATH"
exec "\$venv/bin/python" -c 'import sys; sys.argv[0] = "plotter"; from plotter_bridge.cli.main import main; sys.exit(main())' "\$@"
EOF
chmod +x "$VENV/bin/plotter"

# --- 6. Firmware ---------------------------------------------------------------------
if [ -f firmware/Makefile ]; then
    log "make -C firmware"
    make -s -C firmware
    # The mock board of a machine with a Z axis (plotter --z-axis) runs this core.
    log "make -C firmware ZAXIS=1 build/z/libplotter_core.so"
    make -s -C firmware ZAXIS=1 build/z/libplotter_core.so
    # The mock board with a sheet under its pen (line following) runs this one.
    log "make -C firmware FOLLOW=1 build/follow/libplotter_core.so"
    make -s -C firmware FOLLOW=1 build/follow/libplotter_core.so
fi

log "done: source .venv/bin/activate && source ros_ws/install/setup.bash"
