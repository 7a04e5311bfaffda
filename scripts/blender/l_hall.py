# SPDX-License-Identifier: MIT
"""An L-shaped hall with one slanted wall, modelled in Blender and exported as glTF 2.0.

    blender -b --factory-startup --python scripts/blender/l_hall.py -- [out.gltf] \
        [--preview-dir DIR | --no-preview]

Default output: data/scenes/import/l_hall.gltf. Positions are glTF coordinates (x, y up, z),
metres. The floor outline (wall centre line):

    wing A  x 0..8  z 0..3   (8 x 3)
    wing B  x 0..3  z 3..9   (3 x 6)

with the outer corner at (0, 0) cut at 45 degrees from (1.5, 0) to (0, 1.5) (a 2.12 m slanted
wall). Height 3 m. Modelled the way an artist often does a hall: the floor outline's edges
extruded up into one ring of wall quads facing the room, thickened 0.15 m about the centre
line by a live Solidify modifier (applied on export); the floor and the ceiling are single
n-gon planes (one-sided) over the same outline. A bench, a plinth with a flat-shaded
icosphere on it, a point light and a camera.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import scene_kit as k  # noqa: E402

H = 3.0
OUTLINE = [(1.5, 0.0), (8.0, 0.0), (8.0, 3.0), (3.0, 3.0), (3.0, 9.0), (0.0, 9.0), (0.0, 1.5)]

out, preview_dir = k.parse_args("l_hall")
k.reset_scene()

plaster = k.material("Plaster", (0.78, 0.77, 0.74), 0.85)
stone = k.material("StoneFloor", (0.50, 0.48, 0.45), 0.6)
ceiling_white = k.material("CeilingWhite", (0.88, 0.88, 0.88), 0.9)
oak = k.material("BenchOak", (0.45, 0.30, 0.16), 0.5)
marble = k.material("Marble", (0.80, 0.80, 0.78), 0.25)
bronze = k.material("Bronze", (0.55, 0.35, 0.15), 0.35, metallic=1.0)

k.wall_ring("Walls", OUTLINE, H, 0.15, 0.0, [plaster], inward=True)
k.plane("Floor", OUTLINE, 0.0, True, [stone])
ceiling = k.plane("Ceiling", OUTLINE, H, False, [ceiling_white])

k.parts("Bench", [
    ((-0.9, 0.40, -0.2), (0.9, 0.45, 0.2), 0),   # seat
    ((-0.8, 0.0, -0.18), (-0.74, 0.40, 0.18), 0),  # legs (slabs)
    ((0.74, 0.0, -0.18), (0.8, 0.40, 0.18), 0),
], [oak], (5.5, 0.0, 1.5))
k.parts("Plinth", [((-0.25, 0.0, -0.25), (0.25, 1.1, 0.25), 0)], [marble], (1.5, 0.0, 6.5),
        yaw_deg=30.0)
k.ico_sphere("Sculpture", (1.5, 1.35, 6.5), 0.25, [bronze])

k.point_light("Light_Hall", (2.0, 2.6, 2.0), 250.0, radius=0.15)
k.camera("Camera", (1.5, 1.7, 8.6), (4.5, 1.2, 1.5), lens_mm=20.0)

k.export(out)
if preview_dir:
    k.render_previews(preview_dir, "l_hall", [ceiling], eye=(10.5, 14.0, -5.0),
                      target=(3.0, 0.0, 4.0), lens_mm=26.0)
