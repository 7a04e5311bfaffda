#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Summarises a glTF 2.0 file (.gltf + external .bin) as exported by Blender: per node its
mesh's triangle count, world-space bounds, signed volume (positive: closed with outward
normals, 0: open surface), materials; lights (KHR_lights_punctual: type, intensity, world
position and direction), cameras, materials (base colour, doubleSided), extras, totals.

    scripts/blender/inspect_gltf.py data/scenes/import/flat.gltf [more.gltf ...]

Plain Python 3 standard library; reads what the scene scripts in this folder write (float
POSITION, unsigned INDICES, TRS or matrix nodes). It is a reading aid, not a validator: see
validate_gltf.mjs for that.
"""

import base64
import json
import math
import os
import struct
import sys

COMPONENT = {5120: "b", 5121: "B", 5122: "h", 5123: "H", 5125: "I", 5126: "f"}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def trs_matrix(node):
    if "matrix" in node:
        m = node["matrix"]  # column-major
        return [[m[c * 4 + r] for c in range(4)] for r in range(4)]
    tx, ty, tz = node.get("translation", [0, 0, 0])
    qx, qy, qz, qw = node.get("rotation", [0, 0, 0, 1])
    sx, sy, sz = node.get("scale", [1, 1, 1])
    r = [
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ]
    return [[r[0][0] * sx, r[0][1] * sy, r[0][2] * sz, tx],
            [r[1][0] * sx, r[1][1] * sy, r[1][2] * sz, ty],
            [r[2][0] * sx, r[2][1] * sy, r[2][2] * sz, tz],
            [0, 0, 0, 1]]


def apply(m, p, w=1.0):
    return [m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] * w for i in range(3)]


def det3(m):
    return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))


class Gltf:
    def __init__(self, path):
        self.path = path
        with open(path, encoding="utf-8") as f:
            self.j = json.load(f)
        self.buffers = []
        for b in self.j.get("buffers", []):
            uri = b["uri"]
            if uri.startswith("data:"):
                self.buffers.append(base64.b64decode(uri.split(",", 1)[1]))
            else:
                with open(os.path.join(os.path.dirname(path), uri), "rb") as f:
                    self.buffers.append(f.read())

    def accessor(self, i):
        a = self.j["accessors"][i]
        bv = self.j["bufferViews"][a["bufferView"]]
        fmt = COMPONENT[a["componentType"]]
        n = NCOMP[a["type"]]
        size = struct.calcsize(fmt)
        stride = bv.get("byteStride", size * n)
        base = bv.get("byteOffset", 0) + a.get("byteOffset", 0)
        data = self.buffers[bv["buffer"]]
        out = []
        for e in range(a["count"]):
            vals = struct.unpack_from("<" + fmt * n, data, base + e * stride)
            out.append(vals if n > 1 else vals[0])
        return out


def fmt_num(x, nd=3):
    t = f"{x:.{nd}f}".rstrip("0").rstrip(".")
    return "0" if t in ("-0", "") else t


def fmt_v(v, nd=3):
    return "(" + ", ".join(fmt_num(x, nd) for x in v) + ")"


def report(path):
    g = Gltf(path)
    j = g.j
    lines = [f"# {os.path.basename(path)}"]
    lines.append(f"generator: {j['asset'].get('generator')}, extensionsUsed: "
                 f"{j.get('extensionsUsed', [])}")
    mats = j.get("materials", [])
    lights = j.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    scene = j["scenes"][j.get("scene", 0)]
    total_tris = 0
    mesh_rows, light_rows, cam_rows = [], [], []

    def walk(ni, parent):
        nonlocal total_tris
        node = j["nodes"][ni]
        m = mat_mul(parent, trs_matrix(node))
        if "mesh" in node:
            mesh = j["meshes"][node["mesh"]]
            tris, vol, names = 0, 0.0, []
            lo, hi = [math.inf] * 3, [-math.inf] * 3
            for prim in mesh["primitives"]:
                assert prim.get("mode", 4) == 4, "only triangle lists"
                pos = g.accessor(prim["attributes"]["POSITION"])
                idx = g.accessor(prim["indices"]) if "indices" in prim else list(range(len(pos)))
                tris += len(idx) // 3
                for a, b, c in zip(idx[0::3], idx[1::3], idx[2::3]):
                    p, q, r = pos[a], pos[b], pos[c]
                    vol += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0])
                            + p[2] * (q[0] * r[1] - q[1] * r[0])) / 6.0
                for p in pos:
                    w = apply(m, p)
                    lo = [min(lo[k], w[k]) for k in range(3)]
                    hi = [max(hi[k], w[k]) for k in range(3)]
                mi = prim.get("material")
                names.append(mats[mi]["name"] if mi is not None else "-")
            vol *= det3(m)
            total_tris += tris
            mesh_rows.append(f"| {node.get('name')} | {mesh.get('name')} | {len(mesh['primitives'])}"
                             f" | {tris} | {fmt_v(lo, 3)} | {fmt_v(hi, 3)} | {vol:.3f} | "
                             f"{', '.join(names)} |")
        ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if ext is not None:
            li = lights[ext["light"]]
            pos = apply(m, [0, 0, 0])
            d = apply(m, [0, 0, -1], 0.0)
            n = math.sqrt(sum(x * x for x in d)) or 1.0
            extra = ""
            if li["type"] == "spot":
                s = li.get("spot", {})
                extra = (f"inner {math.degrees(s.get('innerConeAngle', 0)):.1f} deg, outer "
                         f"{math.degrees(s.get('outerConeAngle', math.pi / 4)):.1f} deg")
            light_rows.append(f"| {node.get('name')} | {li['type']} | {fmt_num(li.get('intensity', 1), 2)}"
                              f" | {fmt_v(li.get('color', [1, 1, 1]), 2)} | {fmt_v(pos)} | "
                              f"{fmt_v([x / n for x in d])} | {li.get('range', '-')} | {extra} |")
        if "camera" in node:
            cam = j["cameras"][node["camera"]]
            pos = apply(m, [0, 0, 0])
            d = apply(m, [0, 0, -1], 0.0)
            n = math.sqrt(sum(x * x for x in d)) or 1.0
            p = cam.get("perspective", {})
            cam_rows.append(f"| {node.get('name')} | {cam['type']} | {fmt_v(pos)} | "
                            f"{fmt_v([x / n for x in d])} | yfov {math.degrees(p.get('yfov', 0)):.1f}"
                            f" deg, aspect {fmt_num(p.get('aspectRatio', 0))}, znear "
                            f"{fmt_num(p.get('znear', 0))}, zfar {fmt_num(p.get('zfar', 0))} |")
        for c in node.get("children", []):
            walk(c, m)

    ident = [[1 if r == c else 0 for c in range(4)] for r in range(4)]
    for ni in scene["nodes"]:
        walk(ni, ident)

    lines.append(f"nodes {len(j['nodes'])}, meshes {len(j.get('meshes', []))}, materials "
                 f"{len(mats)}, triangles (instanced, as drawn) {total_tris}, bin bytes "
                 f"{sum(len(b) for b in g.buffers)}")
    lines.append("")
    lines.append("| node | mesh | prims | tris | world min (x, y, z) | world max | signed volume m3 |"
                 " materials |")
    lines.append("|---|---|---|---|---|---|---|---|")
    lines += mesh_rows
    lines.append("")
    lines.append("| light | type | intensity | colour | position | direction | range | cone |")
    lines.append("|---|---|---|---|---|---|---|---|")
    lines += light_rows
    lines.append("")
    lines.append("| camera | type | position | direction | lens |")
    lines.append("|---|---|---|---|---|")
    lines += cam_rows
    lines.append("")
    lines.append("| material | baseColorFactor | metallic | roughness | doubleSided |")
    lines.append("|---|---|---|---|---|")
    for mt in mats:
        pbr = mt.get("pbrMetallicRoughness", {})
        lines.append(f"| {mt.get('name')} | {fmt_v(pbr.get('baseColorFactor', [1, 1, 1, 1]))} | "
                     f"{fmt_num(pbr.get('metallicFactor', 1))} | {fmt_num(pbr.get('roughnessFactor', 1))} | "
                     f"{mt.get('doubleSided', False)} |")
    extras = []

    def find_extras(o, where):
        if isinstance(o, dict):
            for key, v in o.items():
                if key == "extras":
                    extras.append(f"{where}: {json.dumps(v)}")
                find_extras(v, f"{where}.{key}")
        elif isinstance(o, list):
            for i, v in enumerate(o):
                find_extras(v, f"{where}[{i}]")

    find_extras(j, "$")
    lines.append("")
    lines.append("extras: " + ("; ".join(extras) if extras else "none"))
    return "\n".join(lines)


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    print("\n\n".join(report(p) for p in sys.argv[1:]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
