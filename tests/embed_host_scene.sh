#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# ctest embed_host_scene_matches_demo: modrt-embed-host's scene mode against modrt-demo on one
# scene and frame (docs/embedding.md, "The example host's scene mode").
#
#   tests/embed_host_scene.sh WORK_DIR MODRT_BAKE MODRT_LEVEL MODRT_DEMO MODRT_EMBED_HOST COMPARE SCENES_DIR TINY_DICT TINY_LEVEL
#
# A small dictionary (res 8, 4 s to bake), the scene's level (modrt-level --save), modrt-demo's
# frame 0 of data/scenes/host_room.gltf (which also writes the DRT operators it built,
# --save-clutter), then modrt-embed-host's frame 0 of the same scene from those files. The two
# images must agree as the demo's golden image does (delta E mean <= 1, p99 <= 8), and the
# host's frame 12 (its light has moved) must not, so that the comparison can fail. Both run
# --bounces 3: exactly three feedback steps every frame (docs/demo.md). Exit 77 (skipped) where
# no EGL display exists.
set -euo pipefail
work=$1 bake=$2 level=$3 demo=$4 host=$5 compare=$6 scenes=$7 tiny_dict=$8 tiny_level=$9
size_w=320 size_h=180
rm -rf "$work"
mkdir -p "$work"
cd "$work"

# EGL first: the host's atlas mode on the committed tiny assets exits 77 without a display.
set +e
"$host" "$tiny_dict" "$tiny_level" egl_probe.png --scale 1 >egl_probe.log 2>&1
rc=$?
set -e
if ((rc == 77)); then
  echo "embed_host_scene: no EGL display; skipped"
  exit 77
fi
((rc == 0)) || { cat egl_probe.log; exit 1; }

"$bake" -o dict.modrt --res 8 --rays 1024 --sh-rays 256 --probe-grid 2 --lightfield-spatial 6 \
  --lightfield-directional 12 --response-rays 1024 >bake.log
"$level" --level "$scenes/host_room.level.json" --dictionary dict.modrt --save host_room.modrtlevel \
  --out level_out >level.log
"$demo" --scene "$scenes/host_room.gltf" --dictionary dict.modrt --size ${size_w}x${size_h} --frames 1 \
  --bounces 3 --drt-rays 64 --save-clutter host_room.modrtdrt --no-exr --out demo >demo.log 2>&1 ||
  { cat demo.log; exit 1; }
"$host" --scene "$scenes/host_room.gltf" --dictionary dict.modrt --level host_room.modrtlevel \
  --clutter host_room.modrtdrt --out host --frames 13 --width $size_w --height $size_h --bounces 3 >host.log 2>&1 ||
  { cat host.log; exit 1; }
cat host.log
"$compare" demo/frame_0000.png host/frame_0000.png --max-mean 1 --max-p99 8
"$compare" demo/frame_0000.png host/frame_0012.png --max-mean 1 --max-p99 8 --differ
