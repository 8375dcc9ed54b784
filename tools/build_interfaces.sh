#!/usr/bin/env bash
# Build ros2_ws/src/frictionid_interfaces with plain CMake and install it into a
# Python venv that holds ROS 2 from PyPI wheels (see ENVIRONMENT.md, custom
# interfaces, traps 1-3). After this, `import frictionid_interfaces` works in
# that venv with no extra environment variables.
#
# Usage: tools/build_interfaces.sh <absolute venv path>
# Build dir: <repo>/build/frictionid_interfaces (incremental; safe to rerun).
# On a normal ROS 2 install use `colcon build` in ros2_ws instead.
set -euo pipefail

die() { echo "build_interfaces.sh: ERROR: $*" >&2; exit 1; }

[ $# -eq 1 ] || die "usage: $0 <absolute venv path>"
VENV="$1"
case "$VENV" in /*) ;; *) die "venv path must be absolute, got '$VENV'" ;; esac
VENV="${VENV%/}"

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PKG="$REPO/ros2_ws/src/frictionid_interfaces"
BUILD="$REPO/build/frictionid_interfaces"
PY="$VENV/bin/python"

[ -x "$PY" ] || die "no Python at $PY (run 'make setup' / create the venv first)"
[ -f "$PKG/CMakeLists.txt" ] || die "interface package not found at $PKG"
command -v cmake >/dev/null || die "cmake not found on PATH"
for dep in rosidl_default_generators ament_cmake builtin_interfaces std_msgs geometry_msgs action_msgs; do
  [ -d "$VENV/share/$dep/cmake" ] \
    || die "'$dep' is not installed in $VENV (pip install the ROS build tools from requirements.txt)"
done

# Trap 1: the generators are found through AMENT_PREFIX_PATH.
export VIRTUAL_ENV="$VENV"
export AMENT_PREFIX_PATH="$VENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export PATH="$VENV/bin:$PATH"
# find_package() for ament_cmake, rosidl_* and the message packages.
export CMAKE_PREFIX_PATH="$VENV${CMAKE_PREFIX_PATH:+:$CMAKE_PREFIX_PATH}"

# Python module install dir relative to the prefix (e.g. lib/python3.11/site-packages).
PY_INSTALL_DIR="$("$PY" -c 'import sysconfig, os; print(os.path.relpath(sysconfig.get_path("purelib"), sysconfig.get_config_var("base")))')" \
  || die "cannot query $PY"

# A build dir configured for another venv would keep stale cache entries: start over.
if [ -f "$BUILD/CMakeCache.txt" ] \
   && ! grep -qxF "CMAKE_INSTALL_PREFIX:PATH=$VENV" "$BUILD/CMakeCache.txt"; then
  echo "build_interfaces.sh: $BUILD was configured for another prefix; removing it"
  rm -rf "$BUILD"
fi
mkdir -p "$BUILD"

# Trap 3: install straight into the venv prefix -> no runtime env vars needed.
# (Trap 2 is handled in the package's CMakeLists.txt.)
echo "build_interfaces.sh: building frictionid_interfaces into $VENV (build dir $BUILD)"
cmake -S "$PKG" -B "$BUILD" \
    -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_INSTALL_PREFIX="$VENV" \
    -DPython3_EXECUTABLE="$PY" \
    -DPython3_FIND_VIRTUALENV=ONLY \
    -DPYTHON_INSTALL_DIR="$PY_INSTALL_DIR" \
    -DBUILD_TESTING=OFF \
    > "$BUILD/configure.log" 2>&1 \
  || { cat "$BUILD/configure.log" >&2; die "CMake configure failed (log: $BUILD/configure.log)"; }
cmake --build "$BUILD" -j"$(nproc 2>/dev/null || echo 2)" \
  || die "CMake build failed (build dir: $BUILD)"
cmake --install "$BUILD" > "$BUILD/install.log" 2>&1 \
  || { cat "$BUILD/install.log" >&2; die "CMake install into $VENV failed (log: $BUILD/install.log)"; }

# Smoke test in a fresh interpreter (the wheels' bootstrapper sets LD_LIBRARY_PATH).
env -u _ROS_WHEELS_BOOTSTRAP_COMPLETE -u PYTHONPATH "$PY" -c \
  'from frictionid_interfaces.msg import IdentifiedParameters, JointFriction; from frictionid_interfaces.srv import Identify, ParametersFile; from frictionid_interfaces.action import Identify as IdentifyAction, RunExperiment; RunExperiment.Goal(); Identify.Request(); IdentifyAction.Feedback(); IdentifiedParameters()' \
  || die "installed, but 'import frictionid_interfaces' fails in $PY"
echo "build_interfaces.sh: OK, frictionid_interfaces installed into $VENV"
