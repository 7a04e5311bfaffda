#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the DRT clutter sample data/scenes/clutter_room.gltf (one embedded buffer).

    scripts/make_clutter_gltf.py [output_dir]     # default: data/scenes next to this script

Plain Python 3 standard library. Two proxy blocks in a row (marked extras.modrt_block, open
towards each other) and two clutter meshes (extras.modrt_clutter, docs/demo.md): a concave
L-shaped pillar standing in the first block and a box in the second, both closed prisms with
lightmap UVs in TEXCOORD_1 (one chart per side and per cap, each in its own tile of a 3 x 3
grid, inset so that charts never share an atlas cell). A camera in the second block looks at
both; one KHR_lights_punctual point light hangs in the first.

tests/test_gltf_scene.cpp checks the loaded scene against these numbers: change both.
"""

import base64
import json
import math
import os
import struct
import sys

GRID = 3        # tiles per atlas side
INSET = 0.08    # margin inside each tile, as a fraction of the tile


def prism(polygon, cap_triangles, y0, y1):
    """A closed prism over `polygon` (x, z) counter-clockwise in (x, z), between heights y0 and
    y1. cap_triangles: index triples into polygon covering it without T-junctions. Returns
    positions, lightmap uvs and indices; every triangle counter-clockwise seen from outside."""
    area2 = sum(polygon[i][0] * polygon[(i + 1) % len(polygon)][1] - polygon[(i + 1) % len(polygon)][0] * polygon[i][1]
                for i in range(len(polygon)))
    assert area2 > 0, "polygon must be counter-clockwise in (x, z)"
    positions, uvs, indices = [], [], []
    charts = 0

    def tile(u, v):  # (u, v) in [0, 1]^2 -> the chart's tile, inset
        col, row = charts % GRID, charts // GRID
        s = (1.0 - 2.0 * INSET) / GRID
        return ((col + INSET) / GRID + u * s, (row + INSET) / GRID + v * s)

    def add_triangle(a, b, c, outward):
        # Wind so that the geometric normal points along `outward`.
        e1 = [b[k] - a[k] for k in range(3)]
        e2 = [c[k] - a[k] for k in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        return sum(n[k] * outward[k] for k in range(3)) > 0

    # Sides: one quad chart per polygon edge.
    for i in range(len(polygon)):
        (x0, z0), (x1, z1) = polygon[i], polygon[(i + 1) % len(polygon)]
        outward = (z1 - z0, 0.0, -(x1 - x0))  # right of the edge for a counter-clockwise polygon
        base = len(positions)
        quad = [(x0, y0, z0), (x1, y0, z1), (x1, y1, z1), (x0, y1, z0)]
        for k, p in enumerate(quad):
            positions.append(p)
            uvs.append(tile([0, 1, 1, 0][k], [0, 0, 1, 1][k]))
        for t in ((0, 1, 2), (0, 2, 3)):
            a, b, c = (quad[j] for j in t)
            indices += [base + t[0], base + t[1], base + t[2]] if add_triangle(a, b, c, outward) else [
                base + t[0], base + t[2], base + t[1]]
        charts += 1
    # Caps: the polygon scaled into its tile.
    xs, zs = [p[0] for p in polygon], [p[1] for p in polygon]
    size = max(max(xs) - min(xs), max(zs) - min(zs))
    for y, outward in ((y0, (0.0, -1.0, 0.0)), (y1, (0.0, 1.0, 0.0))):
        base = len(positions)
        for x, z in polygon:
            positions.append((x, y, z))
            uvs.append(tile((x - min(xs)) / size, (z - min(zs)) / size))
        for t in cap_triangles:
            a, b, c = ((polygon[j][0], y, polygon[j][1]) for j in t)
            indices += [base + t[0], base + t[1], base + t[2]] if add_triangle(a, b, c, outward) else [
                base + t[0], base + t[2], base + t[1]]
        charts += 1
    assert charts <= GRID * GRID
    return positions, uvs, indices


def look_rotation(eye, target):
    """Quaternion [x, y, z, w] turning the glTF camera's -Z towards target (yaw about +Y, then
    pitch about the turned X; no roll)."""
    d = [target[k] - eye[k] for k in range(3)]
    yaw = math.atan2(-d[0], -d[2])
    pitch = math.atan2(d[1], math.hypot(d[0], d[2]))
    qy = (0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2))
    qx = (math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2))
    # qy * qx
    x1, y1, z1, w1 = qy
    x2, y2, z2, w2 = qx
    return [round(v, 6) for v in (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                                  w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)]


CAMERA_EYE = (1.92, 0.62, 0.92)
CAMERA_TARGET = (0.45, 0.3, 0.35)


def main():
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "data", "scenes")
    # L pillar: arms 0.36 long and 0.16 thick around the corner (0.22, 0.22) of block 0,
    # lifted 2 mm off the floor (no coplanar faces with the wall).
    l_polygon = [(0.22, 0.22), (0.58, 0.22), (0.58, 0.38), (0.38, 0.38), (0.38, 0.58), (0.22, 0.58)]
    # Fan from the corner (0.22, 0.22) over the first five vertices, then the last quad:
    # every cap edge is a polygon edge or shared by two cap triangles (closed, no T-junction).
    l_caps = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]
    box_polygon = [(1.4, 0.35), (1.7, 0.35), (1.7, 0.6), (1.4, 0.6)]
    box_caps = [(0, 1, 2), (0, 2, 3)]
    meshes = [prism(l_polygon, l_caps, 0.002, 0.75), prism(box_polygon, box_caps, 0.002, 0.3)]

    data = b""
    views, accessors, gltf_meshes = [], [], []
    for mi, (positions, uvs, indices) in enumerate(meshes):
        def view(blob, count, kind, component, minmax=None):
            nonlocal data
            while len(data) % 4:
                data += b"\x00"
            views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob)})
            data += blob
            acc = {"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind}
            if minmax:
                acc["min"], acc["max"] = minmax
            accessors.append(acc)
            return len(accessors) - 1

        mins = [min(p[k] for p in positions) for k in range(3)]
        maxs = [max(p[k] for p in positions) for k in range(3)]
        pos = view(b"".join(struct.pack("<3f", *p) for p in positions), len(positions), "VEC3", 5126, (mins, maxs))
        uv = view(b"".join(struct.pack("<2f", *t) for t in uvs), len(uvs), "VEC2", 5126)
        idx = view(b"".join(struct.pack("<H", i) for i in indices), len(indices), "SCALAR", 5123)
        gltf_meshes.append({"name": ["pillar", "box"][mi], "primitives": [
            # glTF numbers TEXCOORD_n from 0 without gaps: the charts are TEXCOORD_0 too (one accessor).
            {"attributes": {"POSITION": pos, "TEXCOORD_0": uv, "TEXCOORD_1": uv}, "indices": idx, "material": mi}]})

    gltf = {
        "asset": {"version": "2.0", "generator": "modrt scripts/make_clutter_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "lamp", "type": "point", "color": [1.0, 0.95, 0.85], "intensity": 410.0}]}},
        "scene": 0,
        "scenes": [{"name": "clutter room", "nodes": [0, 1, 2, 3, 4, 5],
                    "extras": {"modrt_level": {"cell_size": 1.0, "default_albedo": [0.7, 0.7, 0.7]}}}],
        "nodes": [
            {"name": "room", "extras": {"modrt_block": {"cell": [0, 0, 0], "missing": ["+X"],
                                                        "albedo": {"-Z": [0.75, 0.3, 0.25]}}}},
            {"name": "annex", "extras": {"modrt_block": {"cell": [1, 0, 0], "missing": ["-X"],
                                                         "albedo": {"+Z": [0.3, 0.6, 0.35]}}}},
            {"name": "L pillar", "mesh": 0, "extras": {"modrt_clutter": {"res": 48}}},
            {"name": "box", "mesh": 1, "extras": {"modrt_clutter": {"block": 1, "albedo": [0.25, 0.4, 0.8]}}},
            {"name": "lamp", "translation": [0.7, 0.85, 0.7], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            # Looks from the annex's far corner towards the pillar: yaw about +Y, slight pitch down.
            {"name": "camera", "camera": 0, "translation": list(CAMERA_EYE),
             "rotation": look_rotation(CAMERA_EYE, CAMERA_TARGET)},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1.1, "znear": 0.02, "aspectRatio": 1.7778}}],
        "materials": [
            {"name": "terracotta", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.45, 0.3, 1.0]}},
            {"name": "blue", "pbrMetallicRoughness": {"baseColorFactor": [0.25, 0.4, 0.8, 1.0]}},
        ],
        "meshes": gltf_meshes,
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "clutter_room.gltf")
    with open(path, "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    print("wrote", path)


if __name__ == "__main__":
    main()
