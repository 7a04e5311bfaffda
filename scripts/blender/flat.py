# SPDX-License-Identifier: MIT
"""A four-room flat, modelled in Blender and exported as glTF 2.0 (separate .gltf + .bin).

    blender -b --factory-startup --python scripts/blender/flat.py -- [out.gltf] \
        [--preview-dir DIR | --no-preview]

Default output: data/scenes/import/flat.gltf (previews into data/scenes/import/previews/).
All positions below are glTF coordinates (x, y up, z), metres. Wall centre lines lie on the
room rectangles' edges; walls are 0.15 m thick, 2.5 m high, on a floor at y = 0.

    living   x 0..5    z 0..5      (5 x 5)
    bedroom  x 5..7.5  z 0..5      (2.5 x 5)
    hall     x 0..7.5  z 5..7.5    (7.5 x 2.5)
    bath     x 7.5..10 z 5..7.5    (2.5 x 2.5)

Walls along x span a whole side of the flat; walls along z butt against them. Doors
(1.0 x 2.1 m) and one window (1.2 x 1.2 m, sill 0.9 m) are Boolean Difference modifiers on the
wall boxes with hidden cutters, applied on export.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene_kit as k  # noqa: E402

H = 2.5  # ceiling height
T = 0.15  # wall thickness
t = T / 2

out, preview_dir = k.parse_args("flat")
k.reset_scene()

white = k.material("WallWhite", (0.82, 0.82, 0.80), 0.8)
red = k.material("PaintRed", (0.62, 0.06, 0.05), 0.7)
blue = k.material("PaintBlue", (0.06, 0.14, 0.60), 0.7)
ceiling_white = k.material("CeilingWhite", (0.88, 0.88, 0.88), 0.9)
oak = k.material("FloorOak", (0.42, 0.26, 0.13), 0.5)
tiles = k.material("FloorTiles", (0.66, 0.66, 0.64), 0.3)
fabric = k.material("SofaFabric", (0.30, 0.33, 0.38), 0.9)
walnut = k.material("Walnut", (0.30, 0.17, 0.09), 0.45)
linen = k.material("Linen", (0.85, 0.83, 0.78), 0.9)
cabinet_paint = k.material("CabinetWhite", (0.75, 0.72, 0.66), 0.5)

walls = k.collection("Walls")
slabs = k.collection("Slabs")
furniture = k.collection("Furniture")

# Floors: oak under living + bedroom, tiles under hall + bath (slabs 0.2 m thick, out to the
# outer wall faces). Ceiling: one L-shaped slab over the whole flat.
k.box("Floor_Oak", (-t, -0.2, -t), (7.5 + t, 0.0, 5.0 - t), [oak], slabs)
k.box("Floor_Tiles", (-t, -0.2, 5.0 - t), (10.0 + t, 0.0, 7.5 + t), [tiles], slabs)
ceiling = k.prism("Ceiling", [(-t, -t), (7.5 + t, -t), (7.5 + t, 5.0 - t), (10.0 + t, 5.0 - t),
                              (10.0 + t, 7.5 + t), (-t, 7.5 + t)], H, H + 0.2,
                  [ceiling_white], slabs)

# Walls along x (constant z), each a whole side.
south = k.box("Wall_South", (-t, 0.0, -t), (7.5 + t, H, t), [white], walls)
mid = k.box("Wall_Hall_South", (-t, 0.0, 5.0 - t), (10.0 + t, H, 5.0 + t), [white], walls)
k.box("Wall_North", (-t, 0.0, 7.5 - t), (10.0 + t, H, 7.5 + t), [white], walls)
# Walls along z (constant x), between the walls along x.
k.box("Wall_West", (-t, 0.0, t), (t, H, 7.5 - t), [white], walls)
k.box("Wall_Bedroom_East", (7.5 - t, 0.0, t), (7.5 + t, H, 5.0 - t), [blue], walls)
bath_wall = k.box("Wall_Bath_West", (7.5 - t, 0.0, 5.0 + t), (7.5 + t, H, 7.5 - t), [white],
                  walls)
k.box("Wall_East", (10.0 - t, 0.0, 5.0 + t), (10.0 + t, H, 7.5 - t), [white], walls)

# Living / bedroom partition: white, its living-room face painted red (a second material on
# that one face, as assigned in edit mode).
import bmesh  # noqa: E402

bm = k.uv_bmesh()
faces = k.add_box(bm, (5.0 - t, 0.0, t), (5.0 + t, H, 5.0 - t), 0, (5.0, H / 2, 2.5))
bm.normal_update()
for f in faces:
    if f.normal.x < -0.5:  # faces -x: the living room
        f.material_index = 1
k.mesh_object("Wall_Living_Bedroom", bm, [white, red], (5.0, H / 2, 2.5), walls)

# Doors (1.0 x 2.1) and the living-room window (1.2 x 1.2, sill 0.9).
k.cut(mid, k.door_cutter("Cut_Door_Living", "x", 5.0, 4.0), name="Door_Living")
k.cut(mid, k.door_cutter("Cut_Door_Bedroom", "x", 5.0, 6.25), name="Door_Bedroom")
k.cut(bath_wall, k.door_cutter("Cut_Door_Bath", "z", 7.5, 6.25), name="Door_Bath")
k.cut(south, k.window_cutter("Cut_Window_Living", "x", 0.0, 2.5, 1.2, 1.2, 0.9),
      name="Window")

# Furniture: joined boxes (the parts intersect), origin on the floor, turned about +Y.
k.parts("Sofa", [
    ((-1.0, 0.0, -0.45), (1.0, 0.42, 0.45), 0),    # base
    ((-1.0, 0.3, 0.2), (1.0, 0.85, 0.45), 0),      # back
    ((-1.0, 0.0, -0.45), (-0.82, 0.62, 0.45), 0),  # arms
    ((0.82, 0.0, -0.45), (1.0, 0.62, 0.45), 0),
], [fabric], (0.6, 0.0, 2.5), yaw_deg=-90.0, coll=furniture)  # back against the west wall

table = k.parts("Table", [
    ((-0.7, 0.71, -0.4), (0.7, 0.75, 0.4), 0),
    ((-0.65, 0.0, -0.35), (-0.59, 0.71, -0.29), 0),
    ((0.59, 0.0, -0.35), (0.65, 0.71, -0.29), 0),
    ((-0.65, 0.0, 0.29), (-0.59, 0.71, 0.35), 0),
    ((0.59, 0.0, 0.29), (0.65, 0.71, 0.35), 0),
], [walnut], (2.9, 0.0, 2.4), yaw_deg=15.0, coll=furniture)
bevel = table.modifiers.new("Bevel", "BEVEL")
bevel.width = 0.008
bevel.segments = 1

k.parts("Bed", [
    ((-0.8, 0.0, -1.0), (0.8, 0.3, 1.0), 0),      # frame
    ((-0.8, 0.0, -1.05), (0.8, 0.9, -0.98), 0),   # headboard
    ((-0.76, 0.3, -0.98), (0.76, 0.5, 0.97), 1),  # mattress
], [walnut, linen], (6.2, 0.0, 1.15), coll=furniture)

# The cabinet: a unit cube scaled in object mode, the scale not applied (a node scale).
k.parts("Cabinet", [((-0.5, 0.0, -0.5), (0.5, 1.0, 0.5), 0)], [cabinet_paint],
        (1.6, 0.0, 7.15), coll=furniture, scale=(1.2, 2.0, 0.5))

# Lights and camera.
k.point_light("Light_Living", (2.5, 2.2, 2.5), 150.0, radius=0.1)
k.spot_light("Spot_Hall", (3.75, 2.45, 6.25), (3.75, 0.0, 6.25), 200.0, 70.0, blend=0.3)
k.camera("Camera", (0.45, 1.6, 0.45), (4.5, 1.0, 4.5), lens_mm=18.0)

k.export(out)
if preview_dir:
    k.render_previews(preview_dir, "flat", [ceiling], eye=(-1.0, 13.0, -5.0),
                      target=(5.5, 0.0, 4.0), lens_mm=26.0)
