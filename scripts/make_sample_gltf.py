#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the sample glTF scene data/scenes/two_rooms.gltf (+ two_rooms.bin) for modrt-demo.

    scripts/make_sample_gltf.py [output_dir]     # default: data/scenes next to this script

Plain Python 3 standard library. The proxy blocks come from the sidecar
data/scenes/two_rooms.level.json (kept by hand, not written here). The scene:

  * a crate (TRS: translation + uniform scale) in the first block,
  * a bench under a parent node (parent translation, child rotation 30 deg about +Y and
    non-uniform scale) in the second block,
  * a normal-mapped pillar given by a column-major `matrix`, without NORMAL or TANGENT (the
    loader computes flat normals and tangents from TEXCOORD_0), with 8-bit indices,
  * a small cube marked "modrt_dynamic" (32-bit indices),
  * a camera in the corner block looking into the pillar room (yaw and pitch), and one
    KHR_lights_punctual point light.

tests/test_gltf_scene.cpp checks the loaded scene against these numbers: change both.
"""

import base64
import json
import math
import os
import struct
import sys
import zlib


def png_rgba(width, height, pixels):
    """PNG (8-bit RGBA, no filtering) from a list of rows of (r, g, b, a) tuples."""
    raw = b"".join(b"\x00" + bytes(c for px in row for c in px) for row in pixels)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def tile_normal_map(size=16, tiles=2, bevel=0.12):
    """Tangent-space normal map (glTF: +Y up the image) of bevelled square tiles."""

    def height(u, v):
        fu, fv = (u * tiles) % 1.0, (v * tiles) % 1.0
        return min(1.0, min(fu, 1 - fu, fv, 1 - fv) / bevel)

    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            u, v = (x + 0.5) / size, (y + 0.5) / size  # v down the image
            d = 1.0 / size
            dx = (height(u + d, v) - height(u - d, v)) * 0.5
            dy = -(height(u, v + d) - height(u, v - d)) * 0.5  # +Y points up the image
            n = (-dx, -dy, 1.0)
            length = math.sqrt(sum(c * c for c in n))
            row.append(tuple(int(round((c / length * 0.5 + 0.5) * 255)) for c in n) + (255,))
        rows.append(row)
    return png_rgba(size, size, rows)


def checker(size=8):
    a, b = (200, 200, 190, 255), (150, 150, 140, 255)
    return png_rgba(size, size, [[a if (x + y) % 2 == 0 else b for x in range(size)] for y in range(size)])


def box():
    """Unit cube [-0.5, 0.5]^3: 24 vertices (4 per face, outward normals), 36 indices."""
    faces = [  # normal, u axis, v axis
        ((1, 0, 0), (0, 0, -1), (0, 1, 0)),
        ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
        ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
        ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
        ((0, 0, -1), (-1, 0, 0), (0, 1, 0)),
    ]
    pos, nrm, uv, idx = [], [], [], []
    for n, u, v in faces:
        base = len(pos)
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pos.append(tuple(0.5 * (n[i] + su * u[i] + sv * v[i]) for i in range(3)))
            nrm.append(n)
            uv.append(((su + 1) / 2, (1 - sv) / 2))  # glTF v runs down the image
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, uv, idx


# The camera stands in the corner block near its entrance and looks into the pillar room.
CAMERA_POSITION = (0.15, 0.55, 1.15)
CAMERA_TARGET = (1.5, 0.35, 1.75)


def look_at_rotation(eye, target):
    """Quaternion [x, y, z, w] turning a glTF camera (looking along -Z, +Y up) towards
    target with its up in the vertical plane: a yaw about +Y after a pitch about +X."""
    d = [t - e for t, e in zip(target, eye)]
    length = math.sqrt(sum(c * c for c in d))
    d = [c / length for c in d]
    pitch, yaw = math.asin(d[1]), math.atan2(-d[0], -d[2])
    sy, cy, sp, cp = math.sin(yaw / 2), math.cos(yaw / 2), math.sin(pitch / 2), math.cos(pitch / 2)
    return [cy * sp, sy * cp, -sy * sp, cy * cp]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "data", "scenes")
    os.makedirs(out_dir, exist_ok=True)
    pos, nrm, uv, idx = box()

    blob = bytearray()
    views, accessors = [], []

    def add_view(data, target):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob.extend(data)
        return len(views) - 1

    def add_accessor(view, component_type, count, kind, **extra):
        accessors.append(dict({"bufferView": view, "componentType": component_type, "count": count, "type": kind},
                              **extra))
        return len(accessors) - 1

    flat = lambda rows: [c for r in rows for c in r]
    a_pos = add_accessor(add_view(struct.pack("<%df" % (3 * len(pos)), *flat(pos)), 34962), 5126, len(pos), "VEC3",
                         min=[-0.5] * 3, max=[0.5] * 3)
    a_nrm = add_accessor(add_view(struct.pack("<%df" % (3 * len(nrm)), *flat(nrm)), 34962), 5126, len(nrm), "VEC3")
    a_uv = add_accessor(add_view(struct.pack("<%df" % (2 * len(uv)), *flat(uv)), 34962), 5126, len(uv), "VEC2")
    a_i16 = add_accessor(add_view(struct.pack("<%dH" % len(idx), *idx), 34963), 5123, len(idx), "SCALAR")
    a_i8 = add_accessor(add_view(struct.pack("<%dB" % len(idx), *idx), 34963), 5121, len(idx), "SCALAR")
    a_i32 = add_accessor(add_view(struct.pack("<%dI" % len(idx), *idx), 34963), 5125, len(idx), "SCALAR")

    def data_uri(png):
        return "data:image/png;base64," + base64.b64encode(png).decode("ascii")

    full = {"POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv}
    half = math.radians(30.0) / 2
    gltf = {
        "asset": {"version": "2.0", "generator": "modrt scripts/make_sample_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            # 410 cd / 683 lm/W = 0.6 W/sr, the default scene's light.
            {"name": "lamp", "type": "point", "color": [1.0, 0.9, 0.8], "intensity": 410.0}]}},
        "scene": 0,
        "scenes": [{"name": "two rooms", "nodes": [0, 1, 3, 4, 5, 6],
                    "extras": {"modrt_level": {"proxy_walls": True}}}],
        "nodes": [
            {"name": "crate", "mesh": 0, "translation": [0.7, 0.1, 0.3], "scale": [0.2, 0.2, 0.2]},
            {"name": "bench group", "translation": [0.5, 0.0, 1.5], "children": [2]},
            {"name": "bench", "mesh": 1, "translation": [0.0, 0.1, 0.0],
             "rotation": [0.0, math.sin(half), 0.0, math.cos(half)], "scale": [0.4, 0.2, 0.15]},
            {"name": "pillar", "mesh": 2,
             "matrix": [0.1, 0, 0, 0, 0, 0.9, 0, 0, 0, 0, 0.1, 0, 1.8, 0.45, 1.8, 1]},
            {"name": "camera", "camera": 0, "translation": list(CAMERA_POSITION),
             "rotation": look_at_rotation(CAMERA_POSITION, CAMERA_TARGET)},
            {"name": "lamp", "translation": [0.9, 0.8, 1.3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "rolling cube", "mesh": 3, "translation": [1.4, 0.08, 1.5], "scale": [0.16, 0.16, 0.16],
             "extras": {"modrt_dynamic": True}},
        ],
        "cameras": [{"name": "view", "type": "perspective",
                     "perspective": {"yfov": 1.1, "znear": 0.02, "zfar": 50.0, "aspectRatio": 1.5}}],
        "meshes": [
            {"name": "crate", "primitives": [{"attributes": full, "indices": a_i16, "material": 0}]},
            {"name": "bench", "primitives": [{"attributes": full, "indices": a_i16, "material": 1}]},
            {"name": "pillar", "primitives": [{"attributes": {"POSITION": a_pos, "TEXCOORD_0": a_uv},
                                               "indices": a_i8, "material": 2}]},
            {"name": "rolling cube", "primitives": [{"attributes": full, "indices": a_i32, "material": 3}]},
        ],
        "materials": [
            {"name": "painted crate", "pbrMetallicRoughness": {"baseColorFactor": [0.75, 0.62, 0.15, 1.0]}},
            {"name": "wood", "pbrMetallicRoughness": {"baseColorFactor": [0.55, 0.36, 0.2, 1.0]}},
            {"name": "stone", "pbrMetallicRoughness": {"baseColorFactor": [0.62, 0.6, 0.56, 1.0],
                                                       "baseColorTexture": {"index": 1}},
             "normalTexture": {"index": 0, "scale": 0.8}},
            {"name": "white", "pbrMetallicRoughness": {"baseColorFactor": [0.85, 0.85, 0.85, 1.0]}},
        ],
        "textures": [{"source": 0}, {"source": 1}],
        "images": [{"name": "tiles", "uri": data_uri(tile_normal_map())},
                   {"name": "checker", "uri": data_uri(checker())}],
        "buffers": [{"uri": "two_rooms.bin", "byteLength": len(blob)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    with open(os.path.join(out_dir, "two_rooms.bin"), "wb") as f:
        f.write(blob)
    with open(os.path.join(out_dir, "two_rooms.gltf"), "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
