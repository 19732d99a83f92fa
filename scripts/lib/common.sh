# Shared by scripts/demo and scripts/test: install what is missing, build the catkin workspace.
# shellcheck shell=bash
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
WORKSPACE="${DCI_WORKSPACE:-$REPO_ROOT/.build_ws}"
# Debian's ROS tools need Debian's python3 (catkin_pkg lives there), not a pyenv one.
export PATH="/usr/bin:$PATH"

APT_PACKAGES=(
  build-essential cmake ros-core-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev
  libdiagnostic-updater-dev libeigen3-dev libboost-dev libmuparser-dev libyaml-cpp-dev libceres-dev
  libgtest-dev googletest libbenchmark-dev clang libclang-rt-14-dev libbz2-dev libroslz4-dev
  libros-rosgraph-msgs-dev libvisualization-msgs-dev
  python3-rostest python3-rosbag python3-rostopic python3-roslaunch python3-rospy python3-diagnostic-msgs rosbash
  python3-yaml python3-numpy python3-matplotlib
)

log() { printf '\033[1m[die_cushion_ident]\033[0m %s\n' "$*" >&2; }

# The median of the numbers on standard input, one a line (the measuring scripts' runs).
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

ensure_dependencies() {
  local missing=()
  for p in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    return 0
  fi
  log "installing missing packages: ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
}

build_workspace() {
  # The package in the workspace is a directory of links to the repository's entries, not one link to the
  # repository: the repository holds the workspace, and rosrun's `find -L` over the package would otherwise
  # walk back into it ("File system loop detected" on every rosrun).
  local package="$WORKSPACE/src/die_cushion_ident"
  mkdir -p "$WORKSPACE/src"
  if [ -L "$package" ]; then rm "$package"; fi
  mkdir -p "$package"
  local entry name
  for entry in "$REPO_ROOT"/*; do
    name="$(basename "$entry")"
    ln -sfn "$entry" "$package/$name"
  done
  for entry in "$package"/*; do  # entries removed from the repository
    if [ -L "$entry" ] && [ ! -e "$entry" ]; then rm "$entry"; fi
  done
  log "building in $WORKSPACE"
  (cd "$WORKSPACE" && catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      "$@" >"$WORKSPACE/build.log" 2>&1) || { tail -n 60 "$WORKSPACE/build.log"; log "build failed (full log: $WORKSPACE/build.log)"; return 1; }
}

source_workspace() {
  # setup.bash reads unset variables; relax -u while sourcing it.
  set +u
  # shellcheck disable=SC1091
  source "$WORKSPACE/devel/setup.bash"
  set -u
}
