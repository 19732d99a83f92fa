# Shared by scripts/demo and scripts/test: install what is missing, build the catkin workspace.
# shellcheck shell=bash
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
WORKSPACE="${DCI_WORKSPACE:-$REPO_ROOT/.build_ws}"
# Debian's ROS tools need Debian's python3 (catkin_pkg lives there), not a pyenv one.
export PATH="/usr/bin:$PATH"
# ccache keeps the compiled objects beside the workspace, with the paths taken relative to the checkout: a
# second workspace of the same layout inside it (test/install/test_install_space's fresh clone) reuses them.
export CCACHE_DIR="${CCACHE_DIR:-$WORKSPACE/ccache}"
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$REPO_ROOT}"

# The Debian packages: the package's own dependencies come from package.xml (rosdep keys, mapped in
# scripts/lib/rosdep.yaml by scripts/lib/debian_packages.py); these are what reads them, installed first ...
BOOTSTRAP_PACKAGES=(python3 python3-catkin-pkg python3-yaml)
# ... and what the repository's scripts use beyond the package: the compiler, ccache (scripts/test builds the
# install space from a fresh clone on the objects of its own build), git (that clone), clang's fuzzing runtime
# (scripts/fuzz), catkin_lint (scripts/lint), catkin-tools (test/install/test_install_space --catkin-tools).
SCRIPT_PACKAGES=(build-essential ccache catkin-lint catkin-tools clang cmake git libclang-rt-14-dev)

# shellcheck source=scripts/lib/roscore.sh
source "$REPO_ROOT/scripts/lib/roscore.sh"

log() { printf '\033[1m[die_cushion_ident]\033[0m %s\n' "$*" >&2; }

# The median of the numbers on standard input, one a line (the measuring scripts' runs).
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

# Those of the given Debian packages that are not installed, one a line.
missing_packages() {
  local p
  for p in "$@"; do
    [ "$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" = "install ok installed" ] || echo "$p"
  done
}

apt_install() {
  log "installing missing packages: $*"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "$@" >/dev/null
}

ensure_dependencies() {
  local missing packages
  missing=$(missing_packages "${BOOTSTRAP_PACKAGES[@]}")
  # shellcheck disable=SC2086
  if [ -n "$missing" ]; then apt_install $missing; fi
  packages=$(python3 "$REPO_ROOT/scripts/lib/debian_packages.py") || {
    log "package.xml names a rosdep key scripts/lib/rosdep.yaml does not map"
    return 1
  }
  # shellcheck disable=SC2086
  missing=$(missing_packages $packages "${SCRIPT_PACKAGES[@]}")
  # shellcheck disable=SC2086
  if [ -n "$missing" ]; then apt_install $missing; fi
}

link_package() {
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
}

# catkin_make in the workspace as it is laid out, through ccache; arguments go to catkin_make (-D..., targets).
catkin_make_workspace() {
  log "building in $WORKSPACE"
  (cd "$WORKSPACE" && catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
      -DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache \
      "$@" >"$WORKSPACE/build.log" 2>&1) || { tail -n 60 "$WORKSPACE/build.log"; log "build failed (full log: $WORKSPACE/build.log)"; return 1; }
}

build_workspace() {
  link_package
  catkin_make_workspace "$@"
}

source_workspace() {
  # setup.bash reads unset variables; relax -u while sourcing it.
  set +u
  # shellcheck disable=SC1091
  source "$WORKSPACE/devel/setup.bash"
  set -u
}
