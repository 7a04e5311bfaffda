# SPDX-License-Identifier: MIT
"""Shared helpers of the Blender scene scripts in this folder (flat.py, l_hall.py,
window_colonnade.py, building20.py): they model interiors the way an artist does in Blender
(mesh primitives, bmesh, Boolean and Solidify modifiers left live on the objects) and export
them with the stock glTF 2.0 exporter (separate .gltf + .bin, +Y up, modifiers applied,
lights and cameras). Nothing here is tuned for any importer.

Coordinates: the scene scripts give every position in glTF coordinates (x, y up, z), metres,
so that the numbers in their source are the numbers in the exported file; g() turns them into
Blender's Z-up frame (x, -z, y), which the exporter turns back.

Run by Blender only (imported by the scene scripts via sys.path from this folder).
"""

import math
import os
import sys

import bmesh
import bpy
from mathutils import Matrix, Vector


# ----------------------------------------------------------------------------- command line


def parse_args(default_name):
    """Arguments after '--': [out.gltf] [--preview-dir DIR] [--no-preview]."""
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.normpath(os.path.join(here, "..", ".."))
    out = os.path.join(repo, "data", "scenes", "import", default_name + ".gltf")
    preview_dir = None
    preview = True
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--preview-dir":
            preview_dir = argv[i + 1]
            i += 2
            continue
        if a == "--no-preview":
            preview = False
        elif a.startswith("--"):
            raise SystemExit("unknown argument " + a)
        else:
            out = a
        i += 1
    out = os.path.abspath(out)
    if preview and preview_dir is None:
        preview_dir = os.path.join(os.path.dirname(out), "previews")
    return out, (preview_dir if preview else None)


# ----------------------------------------------------------------------------- scene set-up


def g(x, y, z):
    """glTF (x, y up, z) -> Blender (x, y, z up)."""
    return Vector((x, -z, y))


def reset_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"
    scene.unit_settings.scale_length = 1.0
    world = bpy.data.worlds.new("World")
    world.color = (0.05, 0.05, 0.06)
    scene.world = world
    return scene


def collection(name):
    coll = bpy.data.collections.get(name)
    if coll is None:
        coll = bpy.data.collections.new(name)
        bpy.context.scene.collection.children.link(coll)
    return coll


def material(name, rgb, roughness=0.6, metallic=0.0):
    """A Principled BSDF material with the given (linear) base colour."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.get("Principled BSDF")
    bsdf.inputs["Base Color"].default_value = (rgb[0], rgb[1], rgb[2], 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Metallic"].default_value = metallic
    # Viewport / Workbench colour, as an artist's material shows in solid mode.
    mat.diffuse_color = (rgb[0], rgb[1], rgb[2], 1.0)
    mat.roughness = roughness
    return mat


def _link(obj, coll=None):
    (coll or bpy.context.scene.collection).objects.link(obj)
    return obj


def mesh_object(name, bm, mats, location, coll=None, yaw_deg=0.0, scale=(1.0, 1.0, 1.0)):
    """Writes bm into a new mesh object at glTF location, turned yaw_deg about +Y (up),
    scaled by the glTF-axis factors scale (left on the object, as when not applied)."""
    me = bpy.data.meshes.new(name)
    bm.normal_update()
    bm.to_mesh(me)
    bm.free()
    for m in mats:
        me.materials.append(m)
    obj = bpy.data.objects.new(name, me)
    obj.location = g(*location)
    obj.rotation_euler = (0.0, 0.0, math.radians(yaw_deg))
    obj.scale = (scale[0], scale[2], scale[1])
    return _link(obj, coll)


def uv_bmesh():
    """A new bmesh with a UV map, which the primitives below fill as Blender's do."""
    bm = bmesh.new()
    bm.loops.layers.uv.new("UVMap")
    return bm


def add_box(bm, lo, hi, mat_index=0, origin=(0.0, 0.0, 0.0)):
    """Adds a closed box (Blender's cube primitive, outward normals) spanning glTF lo..hi
    (relative to the object's origin, also in glTF coordinates) to bm; returns its faces."""
    blo = g(lo[0] - origin[0], lo[1] - origin[1], hi[2] - origin[2])
    bhi = g(hi[0] - origin[0], hi[1] - origin[1], lo[2] - origin[2])
    res = bmesh.ops.create_cube(bm, size=1.0, calc_uvs=True)  # UVs as the Cube primitive's
    for v in res["verts"]:
        v.co = Vector(tuple(blo[k] + (v.co[k] + 0.5) * (bhi[k] - blo[k]) for k in range(3)))
    faces = {f for v in res["verts"] for f in v.link_faces}
    for f in faces:
        f.material_index = mat_index
    return faces


def box(name, lo, hi, mats, coll=None):
    """A box object (origin at its centre, scale applied) spanning glTF lo..hi."""
    c = tuple((lo[k] + hi[k]) / 2 for k in range(3))
    bm = uv_bmesh()
    add_box(bm, lo, hi, 0, c)
    return mesh_object(name, bm, mats, c, coll)


def parts(name, part_list, mats, location, yaw_deg=0.0, coll=None, scale=(1.0, 1.0, 1.0)):
    """Furniture: several boxes (lo, hi, material index) in the object's own glTF-like frame
    (origin on the floor), joined into one mesh as Ctrl+J would; the boxes may intersect."""
    bm = uv_bmesh()
    for lo, hi, mi in part_list:
        add_box(bm, lo, hi, mi)
    return mesh_object(name, bm, mats, location, coll, yaw_deg, scale)


def prism(name, outline, y0, y1, mats, coll=None):
    """A slab: the polygon outline (glTF (x, z) points) extruded from y0 to y1."""
    # Built face by face (what Extrude Region gives, in a fixed face order: bmesh's extrude
    # orders the side faces differently from run to run).
    bm = bmesh.new()
    n = len(outline)
    lo = [bm.verts.new(g(x, y0, z)) for x, z in outline]
    hi = [bm.verts.new(g(x, y1, z)) for x, z in outline]
    bm.faces.new(lo)
    bm.faces.new(hi)
    for i in range(n):
        j = (i + 1) % n
        bm.faces.new((lo[i], lo[j], hi[j], hi[i]))
    bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
    return mesh_object(name, bm, mats, (0.0, 0.0, 0.0), coll)


def plane(name, outline, y, up, mats, coll=None):
    """A single n-gon at height y over the polygon outline, facing up (floor) or down
    (ceiling) - a one-sided surface, as an artist's floor plane is."""
    bm = bmesh.new()
    verts = [bm.verts.new(g(x, y, z)) for x, z in outline]
    face = bm.faces.new(verts)
    bm.normal_update()
    if (face.normal.z > 0) != up:
        face.normal_flip()
    return mesh_object(name, bm, mats, (0.0, 0.0, 0.0), coll)


def wall_ring(name, outline, height, thickness, offset, mats, coll=None, inward=True):
    """Walls as an artist draws them: the floor outline's edges extruded up into a ring of
    quads (normals towards the room when inward), thickened by a live Solidify modifier."""
    bm = bmesh.new()
    lo = [bm.verts.new(g(x, 0.0, z)) for x, z in outline]
    hi = [bm.verts.new(g(x, height, z)) for x, z in outline]
    n = len(outline)
    for i in range(n):
        j = (i + 1) % n
        bm.faces.new((lo[i], lo[j], hi[j], hi[i]))
    bm.normal_update()
    # The room side of each edge: left of it when the outline runs counter-clockwise in the
    # (x, z) plan (positive shoelace area), right of it otherwise.
    area = sum(outline[i][0] * outline[(i + 1) % n][1] - outline[(i + 1) % n][0] * outline[i][1]
               for i in range(n))
    for i, f in enumerate(bm.faces):
        (x0, z0), (x1, z1) = outline[i], outline[(i + 1) % n]
        nx, nz = -(z1 - z0), (x1 - x0)  # left normal in the plan
        if area < 0:
            nx, nz = -nx, -nz
        room_side = g(nx, 0.0, nz)
        if (f.normal.dot(room_side) > 0) != inward:
            f.normal_flip()
    obj = mesh_object(name, bm, mats, (0.0, 0.0, 0.0), coll)
    mod = obj.modifiers.new("Solidify", "SOLIDIFY")
    mod.thickness = thickness
    mod.offset = offset
    mod.use_even_offset = True
    return obj


def cylinder(name, centre_xz, radius, y0, y1, mats, vertices=16, coll=None, mesh=None):
    """A column from Blender's cylinder primitive, smooth shaded with auto smooth (30 deg).
    With mesh given, a linked duplicate (Alt+D) of that mesh."""
    if mesh is None:
        bm = uv_bmesh()
        bmesh.ops.create_cone(bm, cap_ends=True, cap_tris=False, segments=vertices,
                              calc_uvs=True, radius1=radius, radius2=radius, depth=y1 - y0,
                              matrix=Matrix.Translation((0.0, 0.0, (y1 - y0) / 2)))
        me = bpy.data.meshes.new(name)
        bm.normal_update()
        bm.to_mesh(me)
        bm.free()
        for p in me.polygons:
            p.use_smooth = True
        me.use_auto_smooth = True
        me.auto_smooth_angle = math.radians(30.0)
        for m in mats:
            me.materials.append(m)
        mesh = me
    obj = bpy.data.objects.new(name, mesh)
    obj.location = g(centre_xz[0], y0, centre_xz[1])
    return _link(obj, coll)


def ico_sphere(name, centre, radius, mats, subdivisions=2, coll=None):
    """A flat-shaded icosphere. (Not smooth shaded: Blender 3.4 sums smooth vertex normals
    in a thread-dependent order, so a smooth sphere's normals change in their last bits from
    one export to the next; the columns' auto-smooth normals do not.)"""
    bm = uv_bmesh()
    bmesh.ops.create_icosphere(bm, subdivisions=subdivisions, radius=radius, calc_uvs=True)
    return mesh_object(name, bm, mats, centre, coll)


# ----------------------------------------------------------------------------- booleans


def cutter(name, lo, hi):
    """A hidden boolean cutter (box) in the 'Cutters' collection: wireframe in the viewport,
    not renderable, so the export (renderable objects only) leaves it out."""
    coll = collection("Cutters")
    coll.hide_render = True
    # A cutter without any material slot makes the Exact solver of Blender 3.4 give the cut
    # faces arbitrary material indices; with one slot (Index Based mode) they take the cut
    # object's first slot.
    mat = bpy.data.materials.get("Cutter") or material("Cutter", (1.0, 0.2, 0.8))
    obj = box(name, lo, hi, [mat], coll)
    obj.display_type = "WIRE"
    obj.hide_render = True
    return obj


def cut(obj, cutter_obj=None, cutters=None, name="Boolean"):
    """A live Boolean Difference (Exact solver) with one cutter object or a cutter
    collection."""
    mod = obj.modifiers.new(name, "BOOLEAN")
    mod.operation = "DIFFERENCE"
    mod.solver = "EXACT"
    if cutters is not None:
        mod.operand_type = "COLLECTION"
        mod.collection = cutters
    else:
        mod.object = cutter_obj
    return mod


def door_cutter(name, wall_axis, wall_pos, centre, width=1.0, height=2.1, depth=0.4):
    """Cutter for a door in a wall along wall_axis ('x': wall at z = wall_pos, door centred at
    x = centre; 'z': wall at x = wall_pos, door centred at z = centre). It reaches 0.1 m below
    the floor so the opening goes down to the floor."""
    h = width / 2
    if wall_axis == "x":
        return cutter(name, (centre - h, -0.1, wall_pos - depth / 2),
                      (centre + h, height, wall_pos + depth / 2))
    return cutter(name, (wall_pos - depth / 2, -0.1, centre - h),
                  (wall_pos + depth / 2, height, centre + h))


def window_cutter(name, wall_axis, wall_pos, centre, width, height, sill, depth=0.6):
    h = width / 2
    if wall_axis == "x":
        return cutter(name, (centre - h, sill, wall_pos - depth / 2),
                      (centre + h, sill + height, wall_pos + depth / 2))
    return cutter(name, (wall_pos - depth / 2, sill, centre - h),
                  (wall_pos + depth / 2, sill + height, centre + h))


# ----------------------------------------------------------------------------- lights, camera


def _aim(obj, target):
    d = g(*target) - obj.location
    obj.rotation_euler = d.to_track_quat("-Z", "Y").to_euler()


def point_light(name, pos, watts, radius=0.1, colour=(1.0, 1.0, 1.0)):
    data = bpy.data.lights.new(name, "POINT")
    data.energy = watts
    data.shadow_soft_size = radius
    data.color = colour
    obj = bpy.data.objects.new(name, data)
    obj.location = g(*pos)
    return _link(obj)


def spot_light(name, pos, target, watts, cone_deg, blend=0.15, radius=0.05):
    data = bpy.data.lights.new(name, "SPOT")
    data.energy = watts
    data.spot_size = math.radians(cone_deg)
    data.spot_blend = blend
    data.shadow_soft_size = radius
    obj = bpy.data.objects.new(name, data)
    obj.location = g(*pos)
    _link(obj)
    _aim(obj, target)
    return obj


def camera(name, pos, target, lens_mm=18.0):
    data = bpy.data.cameras.new(name)
    data.lens = lens_mm
    data.sensor_width = 36.0
    data.clip_start = 0.05
    data.clip_end = 200.0
    obj = bpy.data.objects.new(name, data)
    obj.location = g(*pos)
    _link(obj)
    _aim(obj, target)
    bpy.context.scene.camera = obj
    return obj


# ----------------------------------------------------------------------------- export, preview


def export(out):
    os.makedirs(os.path.dirname(out), exist_ok=True)
    bpy.ops.export_scene.gltf(
        filepath=out,
        export_format="GLTF_SEPARATE",
        export_yup=True,
        export_apply=True,
        export_lights=True,
        export_cameras=True,
        use_renderable=True,  # leaves out the hidden boolean cutters
    )
    print("scene_kit: wrote", out)


def render_previews(preview_dir, stem, hide, eye, target, lens_mm=24.0):
    """Two Workbench pictures (480x360): <stem>_cutaway.png from a preview camera at eye
    looking at target with the objects in hide (ceilings) left out, and <stem>_camera.png
    from the scene's own camera with everything. Call after export(): the preview camera is
    not in the file."""
    os.makedirs(preview_dir, exist_ok=True)
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x = 480
    scene.render.resolution_y = 360
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 90
    shading = scene.display.shading
    shading.light = "STUDIO"
    shading.color_type = "MATERIAL"
    shading.show_cavity = True
    shading.show_object_outline = True
    shading.show_shadows = True
    scene_cam = scene.camera

    scene.render.filepath = os.path.join(preview_dir, stem + "_camera.png")
    bpy.ops.render.render(write_still=True)

    hidden = []
    for obj in hide:
        if not obj.hide_render:
            obj.hide_render = True
            hidden.append(obj)
    data = bpy.data.cameras.new("PreviewCamera")
    data.lens = lens_mm
    cam = bpy.data.objects.new("PreviewCamera", data)
    cam.location = g(*eye)
    _link(cam)
    _aim(cam, target)
    scene.camera = cam
    scene.render.filepath = os.path.join(preview_dir, stem + "_cutaway.png")
    bpy.ops.render.render(write_still=True)
    for obj in hidden:
        obj.hide_render = False
    scene.camera = scene_cam
