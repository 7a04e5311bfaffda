#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Install the Debian 12 packages modrt needs to build, test and run its demo.
#
#   scripts/install-deps.sh            # default set (build, tests, demo)
#   scripts/install-deps.sh --cross    # also the aarch64 cross toolchain and qemu-user
#
# Only missing packages are installed; when everything is present the script makes no
# network access and finishes in well under a second. Uses sudo when not run as root.
set -euo pipefail

usage() {
  sed -n '3,9p' "$0" | sed 's/^# \{0,1\}//'
}

with_cross=0
for arg in "$@"; do
  case "$arg" in
    --cross) with_cross=1 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "install-deps: unknown argument '$arg'" >&2; usage >&2; exit 2 ;;
  esac
done

packages=(
  # toolchain
  build-essential cmake pkg-config clang
  # core / precompute
  libglm-dev libembree-dev libeigen3-dev libtbb-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev python3-matplotlib
  # programs: command line, image and scene I/O
  libcli11-dev libopenimageio-dev libtinygltf-dev nlohmann-json3-dev libstb-dev
  # GL ES / EGL / OSMesa (software rendering, headless)
  libegl-dev libgles-dev libosmesa6-dev libegl-mesa0 libgl1-mesa-dri
)
# Node.js runs the Khronos glTF validator in the tests (import_scenes); Debian's when none is on PATH.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi
cross_packages=(g++-aarch64-linux-gnu qemu-user)
if ((with_cross)); then
  packages+=("${cross_packages[@]}")
fi

is_installed() {
  # One status line per installed architecture; any fully installed one counts.
  dpkg-query -W -f='${Status}\n' "$1" 2>/dev/null | grep -qx 'install ok installed'
}

if ! command -v dpkg-query >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1; then
  echo "install-deps: dpkg/apt-get not found; this script supports Debian 12 only." >&2
  echo "install-deps: install these packages by other means: ${packages[*]}" >&2
  exit 1
fi

# The Khronos glTF validator (npm package, pinned), into the user's cache folder; the tests
# find it there (tests/import_scenes.sh). Run at exit, after any apt-get.
install_gltf_validator() {
  local prefix="${XDG_CACHE_HOME:-$HOME/.cache}/modrt/npm"
  if [[ -f "$prefix/node_modules/gltf-validator/package.json" ]]; then return 0; fi
  command -v npm >/dev/null 2>&1 || return 0
  echo "install-deps: installing the Khronos glTF validator into $prefix"
  mkdir -p "$prefix"
  npm install --no-audit --no-fund --prefix "$prefix" gltf-validator@2.0.0-dev.3.10 >/dev/null ||
    echo "install-deps: npm could not install gltf-validator (the import_scenes test needs it)" >&2
}
trap 'status=$?; if ((status == 0)); then install_gltf_validator; fi' EXIT

missing=()
for pkg in "${packages[@]}"; do
  is_installed "$pkg" || missing+=("$pkg")
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages already installed."
  exit 0
fi

if [[ $(id -u) -eq 0 ]]; then
  sudo_cmd=()
elif command -v sudo >/dev/null 2>&1; then
  sudo_cmd=(sudo)
else
  echo "install-deps: missing packages: ${missing[*]}" >&2
  echo "install-deps: not running as root and sudo is not available; install them as root:" >&2
  echo "  apt-get update && apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi

echo "install-deps: installing ${#missing[@]} missing package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt_env=(env DEBIAN_FRONTEND=noninteractive)  # survives sudo's environment reset

if ! "${sudo_cmd[@]}" "${apt_env[@]}" apt-get update; then
  echo "install-deps: 'apt-get update' failed (network or apt sources?)." >&2
  exit 1
fi
if ! "${sudo_cmd[@]}" "${apt_env[@]}" apt-get install -y --no-install-recommends "${missing[@]}"; then
  echo "install-deps: 'apt-get install' failed for: ${missing[*]}" >&2
  echo "install-deps: these are Debian 12 (bookworm) package names; check /etc/apt/sources.list*." >&2
  exit 1
fi

still_missing=()
for pkg in "${missing[@]}"; do
  is_installed "$pkg" || still_missing+=("$pkg")
done
if ((${#still_missing[@]} != 0)); then
  echo "install-deps: still not installed after apt-get: ${still_missing[*]}" >&2
  exit 1
fi
echo "install-deps: done."
