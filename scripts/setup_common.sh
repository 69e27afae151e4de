# Shared by scripts/demo and scripts/test: install what is missing, configure, build.
# Sourced, not run. Sets WCH_ROOT and WCH_BUILD.
set -euo pipefail
WCH_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# Not "build/": rosrun skips executables under <pkg>/build/.
WCH_BUILD=${WCH_BUILD:-$WCH_ROOT/_build}

# Every Debian 12 package the package needs to build, test and demo (keep complete: CI gets a
# fresh machine). ROS 1 comes from Debian itself (ros-core-dev and friends).
WCH_PACKAGES=(
  build-essential cmake pkg-config git
  ros-core-dev python3-rostest rosbash python3-rospy tf2-tools
  librosbag-dev libtopic-tools-dev libstd-srvs-dev python3-rosbag python3-std-srvs
  libnodeletlib-dev libnodelet-dev libnodeletlib-tools
  python3-geometry-msgs
  libtf2-ros-dev libtf2-eigen-dev libvisualization-msgs-dev
  liboctomap-dev libdynamicedt3d-dev
  libeigen3-dev libyaml-cpp-dev libcairo2-dev libgtest-dev libtbb-dev
  gnuplot-nox clang libclang-rt-14-dev clang-format
)
# Only scripts/rviz_shot needs these (RViz under a virtual X server, and `import` for the PNG);
# kept apart so that building and testing do not pull in RViz and Qt.
WCH_RVIZ_SHOT_PACKAGES=(rviz xvfb imagemagick)

wch_install_packages() {  # [PACKAGE...]: those instead of WCH_PACKAGES
  local wanted=("$@")
  if [ ${#wanted[@]} -eq 0 ]; then wanted=("${WCH_PACKAGES[@]}"); fi
  local missing=()
  for p in "${wanted[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then return 0; fi
  echo "== installing Debian packages: ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
}

wch_build() {
  # Debian's python3 must configure catkin (a pyenv python3 first on PATH cannot see it).
  if [ ! -f "$WCH_BUILD/CMakeCache.txt" ]; then
    cmake -S "$WCH_ROOT" -B "$WCH_BUILD" -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3
  fi
  # The python messages (rospy clients, tests) are not part of "all".
  cmake --build "$WCH_BUILD" -j"$(nproc)" --target all wet_curly_hair_generate_messages "$@"
}

wch_bin() {  # path of a built executable
  echo "$WCH_BUILD/devel/lib/wet_curly_hair/$1"
}
