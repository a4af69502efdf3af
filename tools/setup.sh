#!/usr/bin/env bash
# One-command, idempotent set-up for bullet_floor_sim (called by `make setup`).
#
#   1. apt-installs the ROS 1 packages (Debian 12's own packages, or ros-noetic-* on Ubuntu 20.04)
#   2. creates .venv/ from the system python3 with --system-site-packages (ROS's Python lives there)
#   3. installs the pinned PyPI packages (requirements/venv.txt, requirements/constraints.txt),
#      with numpy pinned to the system's numpy
#   4. creates a catkin workspace (src/bullet_floor_sim -> this repo) and runs catkin_make with
#      the venv active, so node wrappers run the venv's interpreter. The workspace lives OUTSIDE
#      the package ($BFS_WS, default ~/.cache/bullet_floor_sim/ws-<hash of this path>): a
#      workspace inside the package it links to makes a directory loop, and rosrun's `find -L`
#      then finds every node several times and stops to ask which one. .ws/devel/setup.bash is
#      a one-line file that sources the real one.
#
# Safe to re-run: every step checks what is already there.
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$REPO/.venv"
WS="${BFS_WS:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/bullet_floor_sim/ws-$(printf %s "$REPO" | sha1sum | cut -c1-8)}"
SHIM="$REPO/.ws/devel/setup.bash"
SYS_PY=/usr/bin/python3
log() { printf '[setup] %s\n' "$*"; }
die() { printf '[setup] error: %s\n' "$*" >&2; exit 1; }

. /etc/os-release
case "${ID}:${VERSION_CODENAME:-}" in
  debian:bookworm|debian:trixie)
    ROS_SETUP=""
    APT_PKGS=(ros-base-dev catkin rosbash python3-venv python3-numpy python3-scipy python3-yaml python3-pil
      python3-lxml python3-rospy python3-rostest librostest-dev python3-rosbag python3-roslaunch python3-rosunit
      python3-tf2-ros python3-actionlib python3-interactive-markers python3-genpy
      ros-message-generation ros-message-runtime ros-robot-state-publisher
      ros-std-msgs python3-std-msgs ros-geometry-msgs python3-geometry-msgs ros-nav-msgs
      python3-nav-msgs ros-sensor-msgs python3-sensor-msgs ros-visualization-msgs
      python3-visualization-msgs ros-std-srvs python3-std-srvs ros-move-base-msgs
      python3-move-base-msgs ros-map-msgs python3-map-msgs python3-rosgraph-msgs
      python3-tf2-msgs python3-actionlib-msgs python3-tf2-geometry-msgs python3-matplotlib
      python3-skimage python3-pandas catkin-lint rviz)
    ;;
  ubuntu:focal)
    ROS_SETUP=/opt/ros/noetic/setup.bash
    [ -f "$ROS_SETUP" ] || [ -n "$(ls /etc/apt/sources.list.d/ 2>/dev/null | grep -i ros)" ] || \
      die "Ubuntu 20.04: add the ROS Noetic apt repository first (http://wiki.ros.org/noetic/Installation/Ubuntu)"
    APT_PKGS=(ros-noetic-ros-base ros-noetic-robot-state-publisher ros-noetic-xacro ros-noetic-rviz
      ros-noetic-tf2-ros ros-noetic-actionlib ros-noetic-interactive-markers ros-noetic-nav-msgs
      ros-noetic-sensor-msgs ros-noetic-visualization-msgs ros-noetic-std-srvs
      ros-noetic-move-base-msgs ros-noetic-map-msgs ros-noetic-rostest ros-noetic-rosbag
      ros-noetic-tf2-geometry-msgs python3-matplotlib python3-skimage
      python3-venv python3-numpy python3-scipy python3-yaml python3-pil python3-lxml python3-catkin-lint
      python3-pandas)
    ;;
  *) die "unsupported system ${PRETTY_NAME:-unknown}: use Debian 12 or Ubuntu 20.04 + ROS Noetic" ;;
esac

# 1. apt packages (only what is missing)
missing=()
for p in "${APT_PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed' || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO=sudo
  log "apt-get install ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
else
  log "system packages: all present"
fi
[ -n "$ROS_SETUP" ] && { set +u; . "$ROS_SETUP"; set -u; }

# 2. venv from the system interpreter (ROS 1's Python packages are importable only by it)
if [ ! -x "$VENV/bin/python" ] || ! grep -q "include-system-site-packages = true" "$VENV/pyvenv.cfg" 2>/dev/null; then
  log "creating $VENV"
  rm -rf "$VENV"
  "$SYS_PY" -m venv --system-site-packages "$VENV"
fi

# 3. pinned PyPI packages; numpy pinned to the system's own numpy
SYS_NUMPY="$("$SYS_PY" -c 'import numpy; print(numpy.__version__)')"
CONSTRAINTS="$VENV/constraints.txt"
{ cat "$REPO/requirements/constraints.txt"; echo "numpy==$SYS_NUMPY"; } > "$CONSTRAINTS.new"
STAMP="$VENV/.requirements.sha"
want="$(cat "$CONSTRAINTS.new" "$REPO/requirements/venv.txt" | sha256sum | cut -d' ' -f1)"
if [ "$(cat "$STAMP" 2>/dev/null)" != "$want" ]; then
  mv "$CONSTRAINTS.new" "$CONSTRAINTS"
  log "pip install (pinned)"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check \
    -r "$REPO/requirements/venv.txt" -c "$CONSTRAINTS"
  echo "$want" > "$STAMP"
else
  rm -f "$CONSTRAINTS.new"
  log "python packages: up to date"
fi
"$VENV/bin/python" - <<'PY'
import numpy, pybullet, xacro, yourdfpy, shapely, pymongo, rospy  # noqa: F401
PY

# 3b. optional: a MongoDB wire-protocol server for the store tests (test/unit/mongo_server.py).
# Debian 12 has no mongod; mongoeco needs Python >= 3.13. Made only where such an interpreter
# exists (BFS_NO_MONGO=1 skips it); without it those tests are skipped with a warning.
MONGO_VENV="$REPO/.venv-mongo"
PY313=""
for cand in python3.13 python3.14 /usr/bin/python3.13 /usr/local/bin/python3.13 \
    "${PYENV_ROOT:-$HOME/.pyenv}"/versions/3.1[3-9]*/bin/python3; do
  if "$cand" -c 'import sys, venv; sys.exit(sys.version_info < (3, 13))' >/dev/null 2>&1; then
    PY313="$(command -v "$cand")"; break
  fi
done
if [ -z "${BFS_NO_MONGO:-}" ] && [ -n "$PY313" ] && ! command -v mongod >/dev/null; then
  if ! "$MONGO_VENV/bin/python" -c 'import mongoeco, pymongo' 2>/dev/null; then
    log "creating $MONGO_VENV (mongoeco wire server for the MongoDB store tests)"
    rm -rf "$MONGO_VENV"
    if ! { "$PY313" -m venv "$MONGO_VENV" && "$MONGO_VENV/bin/python" -m pip install -q \
        --disable-pip-version-check "mongoeco[wire]==4.11.0" "pymongo==4.20.0"; }; then
      rm -rf "$MONGO_VENV"
      log "warning: could not set up $MONGO_VENV; the MongoDB store tests will be skipped"
    fi
  else
    log "mongoeco test server: present"
  fi
fi

# 4. catkin workspace with a link to the repo, built with the venv active
[ -e "$REPO/.ws/src" ] && rm -rf "$REPO/.ws"   # an old in-package workspace: see the header
mkdir -p "$WS/src"
ln -sfn "$REPO" "$WS/src/bullet_floor_sim"
log "catkin_make in $WS"
(
  set +u
  . "$VENV/bin/activate"
  cd "$WS"
  catkin_make -DPYTHON_EXECUTABLE="$VENV/bin/python" >"$WS/catkin_make.log" 2>&1 \
    || { tail -40 "$WS/catkin_make.log"; exit 1; }
)
mkdir -p "$(dirname "$SHIM")"
printf '# Written by tools/setup.sh: the catkin workspace of this checkout lives outside it.\nsource "%s/devel/setup.bash"\n' "$WS" > "$SHIM"
log "done: source $SHIM"
