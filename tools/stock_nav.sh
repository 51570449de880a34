#!/usr/bin/env bash
# The stock ROS navigation stack (ros-planning/navigation, noetic-devel) for nav:=stock.
#   tools/stock_nav.sh build SOURCE       build it (make stock-nav NAV_SRC=SOURCE)
#   tools/stock_nav.sh setup-file SOURCE  print the built workspace's devel/setup.bash ('' when none)
# SOURCE is a clone of the repository (a directory) or a tarball of one. The packages nav:=stock
# needs are built in a catkin workspace of their own, outside the checkout (their package.xml
# files would otherwise shadow an installed move_base), shared by every clone on the machine:
#   STOCK_NAV_WS (default ${XDG_CACHE_HOME:-~/.cache}/marl_mrta/stock_nav/<hash of SOURCE>)
# Idempotent: a second run with the same source builds nothing. Debian 12 only; on Ubuntu 20.04
# the ros-noetic-* packages (tools/bootstrap.sh) are used and nothing is built.
set -euo pipefail

packages=(
  nav_core costmap_2d voxel_grid base_local_planner navfn dwa_local_planner
  clear_costmap_recovery rotate_recovery move_base fake_localization amcl map_server
)
debian_pkgs=(
  build-essential cmake catkin ros-cmake-modules libbullet-dev libsdl1.2-dev libsdl-image1.2-dev
  libyaml-cpp-dev libeigen3-dev libboost-dev libangles-dev libdiagnostic-updater-dev
  python3-dynamic-reconfigure libdynamic-reconfigure-config-init-mutex-dev libtf2-sensor-msgs-dev
  libtf2-geometry-msgs-dev libtf2-ros-dev liblaser-geometry-dev libmap-msgs-dev librosbag-dev
  libmessage-filters-dev pluginlib-dev libactionlib-dev libmove-base-msgs-dev
  libnav-msgs-dev libsensor-msgs-dev libstd-srvs-dev libvisualization-msgs-dev libroscpp-dev
  librosconsole-dev ros-message-generation ros-message-runtime python3-rospy
)

usage() {
  echo "usage: tools/stock_nav.sh build|setup-file SOURCE (a clone of ros-planning/navigation, noetic-devel, or a tarball of one)" >&2
  exit 2
}

[ $# -eq 2 ] || usage
command=$1
src=$2

. /etc/os-release
os="${ID:-unknown}-${VERSION_ID:-unknown}"

# The workspace of SOURCE: a tarball by its content, a directory by where it is (its build
# follows the clone's changes incrementally).
workspace_of() {
  if [ -n "${STOCK_NAV_WS:-}" ]; then
    echo "$STOCK_NAV_WS"
    return
  fi
  local key
  if [ -d "$src" ]; then
    key=$(cd "$src" && pwd -P | sha256sum | cut -c1-12)
  else
    key=$(sha256sum "$src" | cut -c1-12)
  fi
  echo "${XDG_CACHE_HOME:-${HOME:?HOME is not set: set STOCK_NAV_WS}/.cache}/marl_mrta/stock_nav/$key"
}

if [ "$command" = setup-file ]; then
  # Quiet: the build's underlay, or nothing (no source, Ubuntu, not built yet).
  [ "$os" = debian-12 ] && [ -n "$src" ] && [ -e "$src" ] || exit 0
  setup=$(workspace_of)/devel/setup.bash
  [ -f "$setup" ] && [ -f "$(workspace_of)/.stock_nav_stamp" ] && echo "$setup"
  exit 0
fi
[ "$command" = build ] || usage

case "$os" in
  ubuntu-20.04)
    echo "stock-nav: Ubuntu 20.04: the installed ros-noetic-* navigation packages are used (tools/bootstrap.sh installs them); nothing to build"
    exit 0
    ;;
  debian-12) ;;
  *)
    echo "stock-nav: unsupported OS '$os' (supported: Debian 12, Ubuntu 20.04 with ROS Noetic)" >&2
    exit 1
    ;;
esac

if [ -z "$src" ]; then
  echo "stock-nav: no source: make stock-nav NAV_SRC=path/to/navigation (git clone -b noetic-devel https://github.com/ros-planning/navigation)" >&2
  exit 1
fi
if [ ! -e "$src" ]; then
  echo "stock-nav: NAV_SRC=$src does not exist" >&2
  exit 1
fi
src=$(cd "$(dirname "$src")" && pwd -P)/$(basename "$src")
if [ -d "$src" ] && [ ! -f "$src/move_base/package.xml" ]; then
  echo "stock-nav: $src is not a clone of ros-planning/navigation (no move_base/package.xml)" >&2
  exit 1
fi

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
ws=$(realpath -m "$(workspace_of)")
case "$ws/" in
  "$here/"*|"$(dirname "$here")/shared/"*)
    echo "stock-nav: STOCK_NAV_WS=$ws is inside the checkout or ../shared, where its packages would shadow an installed move_base; choose another directory" >&2
    exit 1
    ;;
esac
mkdir -p "$ws"
stamp=$ws/.stock_nav_stamp
log=$ws/stock_nav.log
# What was built: a tarball by its content (the same file elsewhere, e.g. another clone's
# ../shared, is the same build), a clone by its path.
if [ -f "$src" ]; then
  identity="sha256=$(sha256sum "$src" | cut -d' ' -f1) packages=${packages[*]}"
else
  identity="clone=$src packages=${packages[*]}"
fi

up_to_date() {
  [ -f "$stamp" ] && [ -f "$ws/devel/setup.bash" ] && [ "$(cat "$stamp")" = "$identity" ] || return 1
  # A clone is up to date while none of its files is newer than the last build.
  [ -f "$src" ] || [ -z "$(find -L "$src" -newer "$stamp" -type f ! -path '*/.git/*' -print -quit)" ]
}
if up_to_date; then
  echo "stock-nav: up to date ($ws)"
  exit 0
fi

fail() {  # the phase that failed, the tail of its log and where the whole log is
  tail -n 40 "$log" >&2
  echo "stock-nav: $1 failed (full log: $log)" >&2
  exit 1
}

if [ "$(id -u)" -eq 0 ]; then SUDO=""; else SUDO="sudo"; fi
todo=()
for p in "${debian_pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || todo+=("$p")
done
: >"$log"
if [ ${#todo[@]} -gt 0 ]; then
  echo "stock-nav: installing ${#todo[@]} system packages (${todo[*]})"
  { $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq &&
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${todo[@]}"; } >>"$log" 2>&1 \
    || fail "apt-get"
fi

start=$SECONDS
rm -f "$stamp"
mkdir -p "$ws/src"
if [ -d "$src" ]; then
  echo "stock-nav: using the clone $src (linked as $ws/src/navigation)"
  rm -rf "$ws/src/navigation"
  ln -sfn "$src" "$ws/src/navigation"
else
  echo "stock-nav: unpacking $(basename "$src") into $ws/src/navigation"
  rm -rf "$ws/src/navigation"
  mkdir -p "$ws/src/navigation"
  members=()
  for p in "${packages[@]}"; do members+=("./$p"); done
  tar xzf "$src" -C "$ws/src/navigation" "${members[@]}" >>"$log" 2>&1 || fail "unpacking $src"
fi
[ -f "$ws/src/CMakeLists.txt" ] || ln -sfn /usr/share/catkin/cmake/toplevel.cmake "$ws/src/CMakeLists.txt"

# Its own underlay only: a project workspace sourced in this shell must not become the stock
# workspace's underlay (which it underlays in turn).
unset CMAKE_PREFIX_PATH ROS_PACKAGE_PATH
# ROS builds with the system interpreter (CMake's FindPython3 would take any python3 on PATH).
export PATH=/usr/bin:/bin:$PATH
jobs=$(nproc)
cmake_args=(-DCATKIN_WHITELIST_PACKAGES="$(IFS=';'; echo "${packages[*]}")" -DCMAKE_BUILD_TYPE=Release
            -DCATKIN_ENABLE_TESTING=OFF -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3)
echo "stock-nav: configuring ${#packages[@]} packages (${packages[*]})"
(cd "$ws" && catkin_make "${cmake_args[@]}" cmake_check_build_system) >>"$log" 2>&1 || fail "configuring"
echo "stock-nav: building with -j$jobs (log: $log)"
(cd "$ws" && catkin_make "${cmake_args[@]}" -j"$jobs") >>"$log" 2>&1 || fail "building"
echo "$identity" >"$stamp"
echo "stock-nav: ready in $((SECONDS - start)) s: $ws/devel/setup.bash (make build overlays the project's workspace on it)"
