#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Regenerates the importer test scenes data/scenes/import/*.gltf (+ .bin) and their preview
# pictures with Blender, then validates them with the Khronos glTF Validator.
#
#   scripts/blender/regenerate.sh             # all four scenes
#   scripts/blender/regenerate.sh flat        # some of them (flat l_hall window_colonnade
#                                             #   building20)
#   scripts/blender/regenerate.sh --install   # first: apt-get install blender,
#                                             #   npm install -g gltf-validator
#
# Needs Blender (Debian 12's blender package, 3.4.1, was used for the committed files) and
# node with the npm package gltf-validator.
set -euo pipefail

repo_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$repo_root"

scenes=()
for arg in "$@"; do
  case "$arg" in
    --install)
      if [[ $(id -u) -eq 0 ]]; then sudo_cmd=(); else sudo_cmd=(sudo); fi
      "${sudo_cmd[@]}" apt-get update
      "${sudo_cmd[@]}" apt-get install -y blender nodejs npm
      "${sudo_cmd[@]}" npm install -g gltf-validator
      ;;
    -h | --help) sed -n '3,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) scenes+=("$arg") ;;
  esac
done
[[ ${#scenes[@]} -gt 0 ]] || scenes=(flat l_hall window_colonnade building20)

out_dir=data/scenes/import
files=()
for s in "${scenes[@]}"; do
  echo "=== $s"
  blender -b --factory-startup --python-exit-code 1 --python "scripts/blender/$s.py" -- "$out_dir/$s.gltf" \
    > "/tmp/blender_$s.log" 2>&1 || { cat "/tmp/blender_$s.log"; exit 1; }
  grep -E '^(scene_kit|building20|Saved|  R[0-9])' "/tmp/blender_$s.log" || true
  files+=("$out_dir/$s.gltf")
done
node scripts/blender/validate_gltf.mjs "${files[@]}"
