# SPDX-License-Identifier: MIT
"""A room with a window and a colonnade in front of a gallery, modelled in Blender and
exported as glTF 2.0 (separate .gltf + .bin).

    blender -b --factory-startup --python scripts/blender/window_colonnade.py -- [out.gltf] \
        [--preview-dir DIR | --no-preview]

Default output: data/scenes/import/window_colonnade.gltf. Positions are glTF coordinates
(x, y up, z), metres. Clear interior (inner wall faces), height 3 m:

    room     x 0..6  z 0..4   (6 x 4)
    gallery  x 0..6  z 4..6   (6 x 2), behind a colonnade on z = 4

The walls are one object: the interior outline's edges extruded up into a ring of quads
facing the room, a live Solidify modifier (0.15 m, thickened outwards), then a live Boolean
Difference cutting the window: 1.5 m wide x 1.2 m high, sill at 0.9 m, centred at x = 3 in
the wall z = 0, open (no glass). The colonnade: 4 round columns (diameter 0.3 m, 16 sides,
smooth shaded with auto smooth, linked duplicates of one mesh) at x = 1.2, 2.4, 3.6, 4.8 on
z = 4 under a 0.3 x 0.3 m beam spanning the room. Floor and ceiling slabs are boxes.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene_kit as k  # noqa: E402

H = 3.0
T = 0.15
OUTLINE = [(0.0, 0.0), (6.0, 0.0), (6.0, 6.0), (0.0, 6.0)]

out, preview_dir = k.parse_args("window_colonnade")
k.reset_scene()

plaster = k.material("Plaster", (0.80, 0.79, 0.76), 0.85)
floor_mat = k.material("Terracotta", (0.55, 0.27, 0.16), 0.6)
ceiling_white = k.material("CeilingWhite", (0.88, 0.88, 0.88), 0.9)
stone = k.material("Sandstone", (0.72, 0.64, 0.50), 0.7)

walls = k.wall_ring("Walls", OUTLINE, H, T, -1.0, [plaster], inward=True)
k.cut(walls, k.window_cutter("Cut_Window", "x", 0.0, 3.0, 1.5, 1.2, 0.9), name="Window")

k.box("Floor", (-T, -0.2, -T), (6.0 + T, 0.0, 6.0 + T), [floor_mat])
ceiling = k.box("Ceiling", (-T, H, -T), (6.0 + T, H + 0.2, 6.0 + T), [ceiling_white])

k.box("Beam", (0.0, H - 0.3, 4.0 - 0.15), (6.0, H, 4.0 + 0.15), [stone])
column = k.cylinder("Column.001", (1.2, 4.0), 0.15, 0.0, H - 0.3, [stone])
for i, x in enumerate((2.4, 3.6, 4.8)):
    k.cylinder(f"Column.{i + 2:03d}", (x, 4.0), 0.15, 0.0, H - 0.3, [], mesh=column.data)

k.point_light("Light_Room", (3.0, 2.6, 2.0), 200.0, radius=0.1)
k.camera("Camera", (5.5, 1.6, 5.6), (1.5, 1.3, 0.0), lens_mm=18.0)

k.export(out)
if preview_dir:
    k.render_previews(preview_dir, "window_colonnade", [ceiling], eye=(3.0, 10.5, -6.0),
                      target=(3.0, 0.5, 3.0), lens_mm=26.0)
