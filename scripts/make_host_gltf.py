#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes data/scenes/host_room.gltf and its proxy blocks host_room.level.json: the scene of
modrt-embed-host's scene mode (docs/embedding.md, "The example host's scene mode") and of the
test that compares its frame with modrt-demo's (ctest embed_host_scene_matches_demo).

    scripts/make_host_gltf.py [output_dir]     # default: data/scenes next to this script

Plain Python 3 standard library, one embedded buffer and one embedded PNG. Two proxy blocks in
a row, open towards each other (the sidecar level file, which modrt-level --save builds too).
The file models its own walls (extras.modrt_level.proxy_walls false): every present face of
the two blocks as 4 x 4 quads, one material per albedo, so that an app draws exactly the
meshes of the file. The room's -X wall is brick, normal-mapped (tangents in the file), and
lit by the vector irradiance; a white sphere in the annex is dynamic (extras.modrt_dynamic,
lit by the probe volume); a closed box in the room is a DRT clutter object
(extras.modrt_clutter, lightmap UVs in TEXCOORD_1). One KHR_lights_punctual point light, one
camera in the annex looking into the room.
"""

import base64
import json
import math
import os
import struct
import sys
import zlib

# Level: block cells, missing faces and per-face albedo (the sidecar level file's terms).
BLOCKS = [
    {"name": "room", "cell": [0, 0, 0], "missing": ["+X"], "albedo": {"-Z": [0.75, 0.3, 0.25]}},
    {"name": "annex", "cell": [1, 0, 0], "missing": ["-X"], "albedo": {"+Z": [0.3, 0.6, 0.35]}},
]
DEFAULT_ALBEDO = [0.7, 0.7, 0.7]
BRICK_WALL = (0, "-X")  # block index, face: the normal-mapped wall
BRICK_COLOR = [0.72, 0.68, 0.62]
SUBDIVISIONS = 4
FACES = ["-X", "+X", "-Y", "+Y", "-Z", "+Z"]

CAMERA_EYE = (1.88, 0.55, 0.86)
CAMERA_TARGET = (0.1, 0.38, 0.42)
LIGHT_POSITION = (0.72, 0.82, 0.62)
SPHERE_CENTRE = (1.22, 0.14, 0.6)
SPHERE_RADIUS = 0.13


def png_rgba(width, height, rows):
    raw = b"".join(b"\x00" + bytes(c for px in row for c in px) for row in rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def brick_normal_map(size=64, rows_of_bricks=4, bevel=0.1):
    """Tangent-space normal map (glTF: +Y up the image) of bevelled bricks in running bond."""

    def height(u, v):
        row = math.floor(v * rows_of_bricks)
        fv = v * rows_of_bricks - row
        fu = (u * rows_of_bricks * 0.5 + 0.5 * (row % 2)) % 1.0
        # Brick edges in brick-height units: u spans two brick heights per brick.
        d = min(fv, 1 - fv, 2.0 * fu, 2.0 * (1 - fu))
        return min(1.0, d / bevel)

    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            u, v = (x + 0.5) / size, (y + 0.5) / size  # v down the image
            d = 1.0 / size
            dx = (height(u + d, v) - height(u - d, v)) * 0.5 * 4.0
            dy = -(height(u, v + d) - height(u, v - d)) * 0.5 * 4.0  # +Y points up the image
            n = (-dx, -dy, 1.0)
            length = math.sqrt(sum(c * c for c in n))
            row.append(tuple(int(round((c / length * 0.5 + 0.5) * 255)) for c in n) + (255,))
        rows.append(row)
    return png_rgba(size, size, rows)


def face_frame(face):
    """Inward normal, and (u, v) axes with u x v = inward normal, of a unit-cube face; the
    corner the face's (0, 0) sits at."""
    axis = "XYZ".index(face[1])
    sign = -1 if face[0] == "+" else 1  # inward
    n = [0, 0, 0]
    n[axis] = sign
    u = [0, 0, 0]
    u[(axis + 1) % 3] = 1
    v = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]]
    origin = [0.0, 0.0, 0.0]
    origin[axis] = 0.0 if face[0] == "-" else 1.0
    for k in range(3):  # the (u, v) = (0, 0) corner: u and v run over [0, 1] from it
        if v[k] < 0:
            origin[k] = 1.0
    return n, u, v, origin


def wall_quads(cell, face):
    """SUBDIVISIONS^2 quads of one face (world), counter-clockwise seen from inside."""
    n, u, v, origin = face_frame(face)
    pos, nrm, tan, uv, idx = [], [], [], [], []
    k = SUBDIVISIONS
    for j in range(k):
        for i in range(k):
            base = len(pos)
            for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)):
                a, b = (i + du) / k, (j + dv) / k
                pos.append(tuple(cell[c] + origin[c] + a * u[c] + b * v[c] for c in range(3)))
                nrm.append(tuple(float(c) for c in n))
                # U along the face's v axis, V down its u axis (glTF's v runs down the image):
                # bitangent cross(n, t) w = u, up the image, with w = -1 (n x v = -u).
                tan.append(tuple(float(c) for c in v) + (-1.0,))
                uv.append((2.0 * b, 2.0 * (1.0 - a)))  # two tiles of the normal map per wall
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    return pos, nrm, tan, uv, idx


def prism(polygon, y0, y1, grid=3, inset=0.08):
    """A closed box over a convex polygon (x, z, counter-clockwise) between heights y0 and y1,
    one lightmap chart per side and cap (TEXCOORD_1 in tiles of a grid x grid atlas)."""
    positions, normals, uvs, indices = [], [], [], []
    charts = 0

    def tile(a, b):
        col, row = charts % grid, charts // grid
        s = (1.0 - 2.0 * inset) / grid
        return ((col + inset) / grid + a * s, (row + inset) / grid + b * s)

    def add(quad_or_poly, normal, params):
        base = len(positions)
        for p, (a, b) in zip(quad_or_poly, params):
            positions.append(p)
            normals.append(normal)
            uvs.append(tile(a, b))
        for t in range(1, len(quad_or_poly) - 1):
            tri = [0, t, t + 1]
            e1 = [quad_or_poly[tri[1]][c] - quad_or_poly[0][c] for c in range(3)]
            e2 = [quad_or_poly[tri[2]][c] - quad_or_poly[0][c] for c in range(3)]
            cr = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
            if sum(cr[c] * normal[c] for c in range(3)) < 0:
                tri = [0, t + 1, t]
            indices.extend(base + x for x in tri)

    for i in range(len(polygon)):
        (x0, z0), (x1, z1) = polygon[i], polygon[(i + 1) % len(polygon)]
        length = math.hypot(x1 - x0, z1 - z0)
        normal = ((z1 - z0) / length, 0.0, -(x1 - x0) / length)
        add([(x0, y0, z0), (x1, y0, z1), (x1, y1, z1), (x0, y1, z0)], normal, [(0, 0), (1, 0), (1, 1), (0, 1)])
        charts += 1
    xs, zs = [p[0] for p in polygon], [p[1] for p in polygon]
    size = max(max(xs) - min(xs), max(zs) - min(zs))
    for y, normal in ((y0, (0.0, -1.0, 0.0)), (y1, (0.0, 1.0, 0.0))):
        add([(x, y, z) for x, z in polygon], normal, [((x - min(xs)) / size, (z - min(zs)) / size) for x, z in polygon])
        charts += 1
    return positions, normals, uvs, indices


def sphere(radius, rings=12, segments=24):
    pos, nrm, idx = [], [], []
    for r in range(rings + 1):
        th = math.pi * r / rings
        for s in range(segments + 1):
            ph = 2 * math.pi * s / segments
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.append(tuple(radius * c for c in n))
            nrm.append(n)
    for r in range(rings):
        for s in range(segments):
            a, b = r * (segments + 1) + s, (r + 1) * (segments + 1) + s
            idx += [a, a + 1, b, a + 1, b + 1, b]  # counter-clockwise seen from outside
    return pos, nrm, idx


def look_rotation(eye, target):
    """Quaternion [x, y, z, w] turning the glTF camera's -Z towards target (no roll)."""
    d = [target[k] - eye[k] for k in range(3)]
    yaw = math.atan2(-d[0], -d[2])
    pitch = math.atan2(d[1], math.hypot(d[0], d[2]))
    x1, y1, z1, w1 = 0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)
    x2, y2, z2, w2 = math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)
    return [round(v, 6) for v in (w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                                  w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2, w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2)]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    out_dir = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "data", "scenes")
    data = bytearray()
    views, accessors = [], []

    def view(blob, count, kind, component, minmax=None):
        while len(data) % 4:
            data.append(0)
        views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob)})
        data.extend(blob)
        acc = {"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        return len(accessors) - 1

    def floats(rows, kind, minmax=False):
        n = len(rows[0])
        blob = b"".join(struct.pack("<%df" % n, *r) for r in rows)
        mm = ([min(r[k] for r in rows) for k in range(n)], [max(r[k] for r in rows) for k in range(n)]) if minmax else None
        return view(blob, len(rows), kind, 5126, mm)

    def uints(values):
        return view(b"".join(struct.pack("<I", i) for i in values), len(values), "SCALAR", 5125)

    materials, material_of = [], {}

    def material(color, brick=False):
        key = (tuple(color), brick)
        if key not in material_of:
            m = {"name": "brick" if brick else "wall %d" % len(materials),
                 "pbrMetallicRoughness": {"baseColorFactor": list(color) + [1.0], "metallicFactor": 0.0}}
            if brick:
                m["normalTexture"] = {"index": 0, "scale": 1.0}
            material_of[key] = len(materials)
            materials.append(m)
        return material_of[key]

    # Walls: one mesh per material, every present face of both blocks.
    wall_parts = {}
    for bi, b in enumerate(BLOCKS):
        for f in FACES:
            if f in b["missing"]:
                continue
            brick = (bi, f) == BRICK_WALL
            color = BRICK_COLOR if brick else b.get("albedo", {}).get(f, DEFAULT_ALBEDO)
            mi = material(color, brick)
            part = wall_parts.setdefault(mi, ([], [], [], [], []))
            pos, nrm, tan, uv, idx = wall_quads(b["cell"], f)
            base = len(part[0])
            part[0].extend(pos), part[1].extend(nrm), part[2].extend(tan), part[3].extend(uv)
            part[4].extend(base + i for i in idx)
    meshes, nodes = [], []
    for mi, (pos, nrm, tan, uv, idx) in sorted(wall_parts.items()):
        attributes = {"POSITION": floats(pos, "VEC3", True), "NORMAL": floats(nrm, "VEC3"),
                      "TEXCOORD_0": floats(uv, "VEC2")}
        if "normalTexture" in materials[mi]:
            attributes["TANGENT"] = floats(tan, "VEC4")
        meshes.append({"name": materials[mi]["name"], "primitives": [
            {"attributes": attributes, "indices": uints(idx), "material": mi}]})
        nodes.append({"name": materials[mi]["name"], "mesh": len(meshes) - 1})

    # The clutter box in the room (a DRT object: closed, TEXCOORD_1 charts).
    box_material = len(materials)
    materials.append({"name": "terracotta", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.45, 0.3, 1.0],
                                                                      "metallicFactor": 0.0}})
    pos, nrm, uv1, idx = prism([(0.55, 0.2), (0.8, 0.2), (0.8, 0.45), (0.55, 0.45)], 0.002, 0.42)
    # glTF numbers TEXCOORD_n from 0 without gaps: the charts are TEXCOORD_0 too (one accessor).
    charts = floats(uv1, "VEC2")
    meshes.append({"name": "crate", "primitives": [{"attributes": {
        "POSITION": floats(pos, "VEC3", True), "NORMAL": floats(nrm, "VEC3"), "TEXCOORD_0": charts,
        "TEXCOORD_1": charts},
        "indices": uints(idx), "material": box_material}]})
    nodes.append({"name": "crate", "mesh": len(meshes) - 1, "extras": {"modrt_clutter": {"res": 24}}})

    # The dynamic sphere in the annex.
    white = len(materials)
    materials.append({"name": "white", "pbrMetallicRoughness": {"baseColorFactor": [0.85, 0.85, 0.85, 1.0],
                                                                 "metallicFactor": 0.0}})
    pos, nrm, idx = sphere(SPHERE_RADIUS)
    meshes.append({"name": "ball", "primitives": [{"attributes": {
        "POSITION": floats(pos, "VEC3", True), "NORMAL": floats(nrm, "VEC3")}, "indices": uints(idx),
        "material": white}]})
    nodes.append({"name": "ball", "mesh": len(meshes) - 1, "translation": list(SPHERE_CENTRE),
                  "extras": {"modrt_dynamic": True}})

    nodes.append({"name": "lamp", "translation": list(LIGHT_POSITION),
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    nodes.append({"name": "camera", "camera": 0, "translation": list(CAMERA_EYE),
                  "rotation": look_rotation(CAMERA_EYE, CAMERA_TARGET)})

    png = brick_normal_map()
    gltf = {
        "asset": {"version": "2.0", "generator": "modrt scripts/make_host_gltf.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "lamp", "type": "point", "color": [1.0, 0.93, 0.82], "intensity": 410.0}]}},
        "scene": 0,
        "scenes": [{"name": "host room", "nodes": list(range(len(nodes))),
                    "extras": {"modrt_level": {"proxy_walls": False}}}],
        "nodes": nodes,
        "cameras": [{"name": "view", "type": "perspective",
                     "perspective": {"yfov": 1.0, "znear": 0.02, "zfar": 20.0, "aspectRatio": 1.7778}}],
        "materials": materials,
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"name": "brick normals", "uri": "data:image/png;base64," + base64.b64encode(png).decode()}],
        "meshes": meshes,
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(data)).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    level = {
        "format": "modrt-level", "version": 1, "name": "host_room",
        "_comment": "Proxy blocks of data/scenes/host_room.gltf (its sidecar level file; "
                    "scripts/make_host_gltf.py writes both).",
        "cell_size": 1.0, "default_albedo": DEFAULT_ALBEDO,
        "blocks": [{k: b[k] for k in ("name", "cell", "missing", "albedo")} for b in BLOCKS],
    }
    level["blocks"][BRICK_WALL[0]]["albedo"][BRICK_WALL[1]] = BRICK_COLOR
    os.makedirs(out_dir, exist_ok=True)
    for name, obj in (("host_room.gltf", gltf), ("host_room.level.json", level)):
        path = os.path.join(out_dir, name)
        with open(path, "w") as f:
            json.dump(obj, f, indent=1)
            f.write("\n")
        print("wrote", path)


if __name__ == "__main__":
    main()
