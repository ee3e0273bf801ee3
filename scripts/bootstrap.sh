#!/usr/bin/env bash
# Installs what tissue_cut needs (Debian 12 packages, through sudo when not root; quick when all
# are present), then configures and builds into build/ (or $BUILD_DIR with extra cmake args).
# Sourced by scripts/demo and scripts/test.
set -euo pipefail

TISSUE_CUT_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# pyenv's python3 may come first on PATH and lacks catkin_pkg: ROS tools want Debian's.
export PATH="/usr/bin:$PATH"

TISSUE_CUT_PACKAGES=(
  build-essential cmake git pkg-config
  catkin python3-catkin-pkg python3-empy python3-rospkg
  libroscpp-dev rosbash python3-roslaunch python3-rostest python3-rosunit
  ros-message-generation ros-message-runtime
  ros-std-msgs ros-std-srvs ros-geometry-msgs ros-visualization-msgs
  libeigen3-dev libyaml-cpp-dev nlohmann-json3-dev libgmsh-dev
  libgtest-dev libbenchmark-dev
  python3-numpy python3-vtk9 python3-meshio
  # the node, its tests and the demo
  libtf2-ros-dev libtf2-geometry-msgs-dev libtf2-msgs-dev libdiagnostic-updater-dev
  libdiagnostic-msgs-dev libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libinteractive-markers-dev librosbag-dev librosbag-storage-dev librostest-dev
  libvisualization-msgs-dev python3-std-msgs python3-geometry-msgs python3-visualization-msgs
  python3-tf2-msgs python3-rostopic python3-rosservice python3-rosnode python3-rosparam
  python3-rospy python3-rosbag rviz xvfb imagemagick python3-pil
)

tissue_cut_install() {
  local missing=()
  for p in "${TISSUE_CUT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "tissue_cut: installing ${#missing[@]} Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}

# tissue_cut_build DIR [cmake args...]
tissue_cut_build() {
  local dir="$1"
  shift
  cmake -S "$TISSUE_CUT_ROOT" -B "$dir" -DPYTHON_EXECUTABLE=/usr/bin/python3 "$@" >"$dir.configure.log" 2>&1 ||
    { cat "$dir.configure.log"; return 1; }
  cmake --build "$dir" -j "$(nproc)"
}
