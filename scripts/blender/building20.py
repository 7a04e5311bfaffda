# SPDX-License-Identifier: MIT
"""A generated single-storey building of 20 rooms (5 x 4 grid of varying sizes), modelled in
Blender and exported as glTF 2.0 (separate .gltf + .bin). For import-time measurement: no
furniture, a modest triangle count.

    blender -b --factory-startup --python scripts/blender/building20.py -- [out.gltf] \
        [--preview-dir DIR | --no-preview]

Default output: data/scenes/import/building20.gltf. Positions are glTF coordinates (x, y up,
z), metres. Column widths along x and row depths along z below; wall centre lines lie on the
grid lines; walls 0.15 m thick, 2.8 m high. Each wall is one long box spanning the whole
building (walls along x: full width; walls along z: between the outer walls along x, through
the inner ones - the boxes intersect at the crossings, as an artist's would). Doors (1.0 x
2.1 m) join neighbouring rooms along a random spanning tree (seed 20) plus 4 extra doors; all
door cutters are in one collection, used by one Boolean (Exact, collection operand) on every
wall. One floor slab and one ceiling slab over the whole building, 4 point lights. The script
prints the room rectangles and doors.
"""

import os
import random
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene_kit as k  # noqa: E402

H = 2.8
T = 0.15
t = T / 2
WIDTHS = [4.0, 3.0, 5.5, 3.5, 6.0]  # columns i = 0..4 along x
DEPTHS = [5.0, 3.0, 4.5, 6.0]  # rows j = 0..3 along z
SEED = 20
EXTRA_DOORS = 4

XS = [sum(WIDTHS[:i]) for i in range(len(WIDTHS) + 1)]
ZS = [sum(DEPTHS[:j]) for j in range(len(DEPTHS) + 1)]
W, D = XS[-1], ZS[-1]
NI, NJ = len(WIDTHS), len(DEPTHS)


def room_name(i, j):
    return f"R{j * NI + i:02d}"


def doors_layout():
    """Spanning tree (randomised depth-first search) plus extra doors; each door as
    (room a, room b, wall axis, wall position, door centre)."""
    rng = random.Random(SEED)
    seen = {(0, 0)}
    stack = [(0, 0)]
    pairs = []
    while stack:
        i, j = stack[-1]
        nbrs = [(i + di, j + dj) for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
                if 0 <= i + di < NI and 0 <= j + dj < NJ and (i + di, j + dj) not in seen]
        if not nbrs:
            stack.pop()
            continue
        n = rng.choice(nbrs)
        seen.add(n)
        pairs.append(((i, j), n))
        stack.append(n)
    tree = {frozenset(p) for p in pairs}
    others = sorted({frozenset(((i, j), (i + di, j + dj))) for i in range(NI) for j in range(NJ)
                     for di, dj in ((1, 0), (0, 1)) if i + di < NI and j + dj < NJ} - tree,
                    key=lambda s: sorted(s))
    extra = rng.sample(others, EXTRA_DOORS)
    doors = []
    for pair in [tuple(sorted(p)) for p in pairs] + [tuple(sorted(p)) for p in extra]:
        (i0, j0), (i1, j1) = pair
        if i0 != i1:  # neighbours along x: the wall along z at x = XS[i1], z in row j0
            lo, hi = ZS[j0], ZS[j0 + 1]
            axis, pos = "z", XS[i1]
        else:  # neighbours along z: the wall along x at z = ZS[j1], x in column i0
            lo, hi = XS[i0], XS[i0 + 1]
            axis, pos = "x", ZS[j1]
        centre = round(rng.uniform(lo + 1.1, hi - 1.1) * 20) / 20
        doors.append((room_name(i0, j0), room_name(i1, j1), axis, pos, centre,
                      frozenset(pair) in tree))
    return doors


out, preview_dir = k.parse_args("building20")
k.reset_scene()

plaster = k.material("WallPlaster", (0.80, 0.80, 0.78), 0.85)
floor_mat = k.material("FloorConcrete", (0.55, 0.55, 0.53), 0.7)
ceiling_white = k.material("CeilingWhite", (0.88, 0.88, 0.88), 0.9)

k.box("Floor", (-t, -0.2, -t), (W + t, 0.0, D + t), [floor_mat])
ceiling = k.box("Ceiling", (-t, H, -t), (W + t, H + 0.2, D + t), [ceiling_white])

doors = doors_layout()
door_cutters = k.collection("Cutters")
for n, (a, b, axis, pos, centre, _) in enumerate(doors):
    k.door_cutter(f"Cut_Door_{a}_{b}", axis, pos, centre)

walls = k.collection("Walls")
wall_objs = []
for j, z in enumerate(ZS):
    wall_objs.append(k.box(f"Wall_Z{z:g}", (-t, 0.0, z - t), (W + t, H, z + t), [plaster], walls))
for i, x in enumerate(XS):
    wall_objs.append(k.box(f"Wall_X{x:g}", (x - t, 0.0, t), (x + t, H, D - t), [plaster], walls))
for w in wall_objs:
    k.cut(w, cutters=door_cutters, name="Doors")

LIGHT_ROOMS = [(0, 0), (3, 0), (1, 2), (4, 3)]
for i, j in LIGHT_ROOMS:
    k.point_light(f"Light_{room_name(i, j)}",
                  ((XS[i] + XS[i + 1]) / 2, 2.5, (ZS[j] + ZS[j + 1]) / 2), 100.0, radius=0.1)
k.camera("Camera", (XS[2] + 0.5, 1.6, ZS[1] + 0.5), (XS[3], 1.2, ZS[2]), lens_mm=18.0)

print("building20: rooms (name: x0..x1, z0..z1 on wall centre lines)")
for j in range(NJ):
    for i in range(NI):
        print(f"  {room_name(i, j)}: x {XS[i]:g}..{XS[i + 1]:g}, z {ZS[j]:g}..{ZS[j + 1]:g}"
              f" ({WIDTHS[i]:g} x {DEPTHS[j]:g})")
print("building20: doors (rooms, wall, centre; 1.0 x 2.1 m)")
for a, b, axis, pos, centre, in_tree in doors:
    where = f"wall z = {pos:g}, x = {centre:g}" if axis == "x" else f"wall x = {pos:g}, z = {centre:g}"
    print(f"  {a}-{b}: {where}{'' if in_tree else ' (extra)'}")

k.export(out)
if preview_dir:
    k.render_previews(preview_dir, "building20", [ceiling], eye=(W / 2, 30.0, -10.0),
                      target=(W / 2, 0.0, D / 2 - 1.0), lens_mm=30.0)
