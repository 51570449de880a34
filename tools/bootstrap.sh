#!/usr/bin/env bash
# Installs everything marl_mrta needs on a fresh machine. Idempotent: a second run
# installs nothing. Uses sudo only when not already root.
#   Debian 12    : Debian's ROS 1 packages + a venv (system site packages) with torch
#   Ubuntu 20.04 : ros-noetic-* from packages.ros.org (incl. the navigation stack) + the same venv,
#                  which also carries its own scipy and matplotlib (requirements.txt: the numpy that
#                  OR-Tools and pandas need is newer than focal's scipy 1.3 and matplotlib 3.1 accept)
# torch comes from PyTorch's CPU wheel index where it is reachable, else from PyPI; one line says which.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${MARL_MRTA_VENV:-$here/.venv}
stamp=$venv/.bootstrap-stamp

if [ "$(id -u)" -eq 0 ]; then SUDO=""; else SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive

. /etc/os-release
os="${ID:-unknown}-${VERSION_ID:-unknown}"

debian_pkgs=(
  build-essential cmake curl ca-certificates catkin catkin-lint googletest libgtest-dev libyaml-cpp-dev
  libroscpp-dev librosconsole-dev libstd-msgs-dev libgeometry-msgs-dev libsensor-msgs-dev
  libnav-msgs-dev libstd-srvs-dev libvisualization-msgs-dev libros-rosgraph-msgs-dev
  libtf2-ros-dev libtf2-geometry-msgs-dev libactionlib-dev libactionlib-msgs-dev
  libmove-base-msgs-dev liblaser-geometry-dev ros-message-generation ros-message-runtime
  libnodeletlib-dev libnodelet-dev libnodeletlib-tools pluginlib-dev
  python3-rospy python3-rostest librostest-dev python3-roslaunch python3-rosunit
  python3-tf2-ros python3-actionlib python3-move-base-msgs python3-nav-msgs
  python3-sensor-msgs python3-geometry-msgs python3-std-msgs python3-std-srvs
  python3-visualization-msgs python3-rosgraph-msgs python3-rostopic python3-rosnode
  python3-rosservice python3-rosmsg rosbash rviz ros-robot-state-publisher
  python3-venv python3-pip python3-yaml python3-numpy python3-scipy python3-matplotlib python3-pytest
  libpng-dev python3-pil
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-nav-msgs ros-std-srvs ros-actionlib-msgs
  ros-move-base-msgs ros-visualization-msgs ros-rosgraph-msgs
  xvfb imagemagick x11-utils
  openssh-server openssh-client python3-paramiko
)
noetic_pkgs=(
  build-essential cmake curl ca-certificates python3-catkin-lint python3-venv python3-pip python3-pytest
  ros-noetic-ros-base ros-noetic-rostest ros-noetic-rviz ros-noetic-robot-state-publisher
  ros-noetic-xacro ros-noetic-tf2-ros ros-noetic-tf2-geometry-msgs ros-noetic-actionlib
  ros-noetic-laser-geometry ros-noetic-move-base-msgs ros-noetic-nav-msgs
  ros-noetic-visualization-msgs ros-noetic-std-srvs ros-noetic-nodelet ros-noetic-pluginlib
  ros-noetic-move-base ros-noetic-amcl ros-noetic-map-server ros-noetic-navfn
  ros-noetic-dwa-local-planner ros-noetic-costmap-2d ros-noetic-fake-localization
  libyaml-cpp-dev libgtest-dev python3-yaml python3-numpy python3-scipy python3-matplotlib libpng-dev python3-pil
  xvfb imagemagick x11-utils
  openssh-server openssh-client python3-paramiko
)

missing() {  # prints the packages of "$@" that dpkg does not have installed
  local p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}

case "$os" in
  debian-12)
    pkgs=("${debian_pkgs[@]}")
    torch_spec="torch==2.13.0"
    ;;
  ubuntu-20.04)
    if [ ! -f /etc/apt/sources.list.d/ros-latest.list ]; then
      echo "bootstrap: Ubuntu 20.04 needs the ROS apt source: see http://wiki.ros.org/noetic/Installation/Ubuntu" >&2
      exit 1
    fi
    pkgs=("${noetic_pkgs[@]}")
    torch_spec="torch>=1.13,<2.5"   # the last releases for Python 3.8
    ;;
  *)
    echo "bootstrap: unsupported OS '$os' (supported: Debian 12, Ubuntu 20.04 with ROS Noetic)" >&2
    exit 1
    ;;
esac

todo=$(missing "${pkgs[@]}")
if [ -n "$todo" ]; then
  echo "bootstrap: installing $(echo "$todo" | wc -l) system packages"
  log=$(mktemp)
  # shellcheck disable=SC2086
  if ! { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq --no-install-recommends $todo; } >"$log" 2>&1; then
    tail -n 30 "$log" >&2
    echo "bootstrap: apt-get failed (full log: $log)" >&2
    exit 1
  fi
  rm -f "$log"
fi

if [ ! -f "$stamp" ] || [ "$here/requirements.txt" -nt "$stamp" ]; then
  [ -x "$venv/bin/python3" ] || /usr/bin/python3 -m venv --system-site-packages "$venv"
  echo "bootstrap: installing Python packages into $venv"
  pip_install() {  # pip's notes about absent local index folders are noise here
    "$venv/bin/python3" -m pip install -q --disable-pip-version-check --no-warn-conflicts "$@" 2>&1 \
      | { grep -v "^WARNING: Location '.*' is ignored" || true; }
    return "${PIPESTATUS[0]}"
  }
  # torch: the CPU build from PyTorch's own index where it is reachable. PyPI's Linux x86_64 wheel
  # is the CUDA build, with gigabytes of nvidia wheels, so PyPI is only the fallback.
  cpu_index=https://download.pytorch.org/whl/cpu
  if ! curl -fsS --max-time 10 -o /dev/null "$cpu_index/torch/" 2>/dev/null; then
    pip_install "$torch_spec"
    source_of_torch="PyPI ($cpu_index is not reachable)"
  elif pip_install --index-url "$cpu_index" "$torch_spec"; then
    source_of_torch="the CPU wheel index ($cpu_index)"
  else
    pip_install "$torch_spec"
    source_of_torch="PyPI ($cpu_index has no $torch_spec)"
  fi
  build_of_torch=$("$venv/bin/python3" -c 'import torch; print("CUDA" if torch.version.cuda else "CPU")')
  echo "bootstrap: $torch_spec from $source_of_torch: the $build_of_torch build"
  pip_install -r "$here/requirements.txt"
  touch "$stamp"
fi
echo "bootstrap: ready ($os, venv $venv)"
