#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# modrt-import on the Blender test scenes (data/scenes/import, made by scripts/blender): every
# scene imports with no markup, writes its report, and its output passes the Khronos glTF
# validator with no error, with TEXCOORD_1 on every primitive of every mesh a node draws.
#   import_scenes.sh MODRT_IMPORT SOURCE_DIR OUT_DIR
set -euo pipefail
tool=$1 src=$2 out=$3
rm -rf "$out"
mkdir -p "$out"
for s in flat l_hall window_colonnade building20; do
  "$tool" "$src/data/scenes/import/$s.gltf" "$out/$s.gltf" --report "$out/$s" --level-json "$out/$s.level.json"
  test -s "$out/$s/plan.png"
  test -s "$out/$s/report.md"
  test -s "$out/$s.level.json"
done
python3 - "$out" <<'PY'
import json, sys, glob
for path in sorted(glob.glob(sys.argv[1] + "/*.gltf")):
    g = json.load(open(path))
    drawn = {n["mesh"] for n in g["nodes"] if "mesh" in n}
    for m in drawn:
        for p in g["meshes"][m]["primitives"]:
            if "TEXCOORD_1" not in p["attributes"]:
                sys.exit(f"{path}: mesh {m} ({g['meshes'][m].get('name', '')}) has a primitive without TEXCOORD_1")
    print(f"{path}: TEXCOORD_1 on every drawn primitive ({len(drawn)} meshes)")
PY
# The validator: scripts/install-deps.sh installs it under the cache folder.
export NODE_PATH="${NODE_PATH:-}:${XDG_CACHE_HOME:-$HOME/.cache}/modrt/npm/node_modules"
node "$src/scripts/blender/validate_gltf.mjs" "$out"/*.gltf
# The project's own sample scenes too (issue 22: clutter_room.gltf once had TEXCOORD_1 without
# TEXCOORD_0): no error.
node "$src/scripts/blender/validate_gltf.mjs" "$src"/data/scenes/*.gltf
