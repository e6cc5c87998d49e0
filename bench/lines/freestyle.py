# Blender Freestyle with its SVG exporter (the render_freestyle_svg add-on shipped with Blender)
# on one mesh, for the peer bench (bench/lines/run.sh, docs/LINES.md "Against other tools").
#
#   blender -b --factory-startup --python bench/lines/freestyle.py -- MESH.obj OUT.svg \
#       --eye X,Y,Z --target X,Y,Z --up X,Y,Z --fov-y DEG --width W --height H [--crease-angle DEG]
#
# MESH.obj: world-space triangles (bench/lines/lines_prep.cpp writes it from any scene vismap
# reads), imported with no axis change. The camera is OpenGL's gluLookAt + vertical field of view:
# Blender's camera also looks down its local -Z with +Y up, so its world matrix is the inverse
# view matrix; sensor fit vertical gives the vertical angle. Freestyle's SVG y is flipped to
# top-left by the exporter (height - y), as our pixel frame.
# Line sets: "contour" (silhouette, border, contour, external contour, material boundary) and
# "crease" (crease only), so the SVG's groups are ViewLayer_contour and ViewLayer_crease and
# `vismap check --lines-from` reads their kinds. --crease-angle is ours (between the normals,
# default 45); Freestyle's is between the faces: 180 - that.
import math
import os
import sys
import time

import bpy
from mathutils import Matrix, Vector

argv = sys.argv[sys.argv.index("--") + 1:]
obj_path, out_svg = argv[0], argv[1]
opts = {"--crease-angle": "45"}
for i in range(2, len(argv), 2):
    opts[argv[i]] = argv[i + 1]
vec = lambda s: Vector(tuple(float(v) for v in s.split(",")))
eye, target, up = vec(opts["--eye"]), vec(opts["--target"]), vec(opts["--up"])
fov_y, W, H = float(opts["--fov-y"]), int(opts["--width"]), int(opts["--height"])
crease = float(opts["--crease-angle"])

t0 = time.time()
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.preferences.addon_enable(module="render_freestyle_svg")
if obj_path.endswith(".ply"):  # Blender's PLY importer changes no axes
    bpy.ops.import_mesh.ply(filepath=obj_path)
else:
    bpy.ops.wm.obj_import(filepath=obj_path, forward_axis="Y", up_axis="Z")
scene = bpy.context.scene
t_import = time.time()

cam_data = bpy.data.cameras.new("camera")
cam = bpy.data.objects.new("camera", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam
cam_data.sensor_fit = "VERTICAL"
cam_data.angle_y = math.radians(fov_y)
f = (target - eye).normalized()
r = f.cross(up).normalized()
u = r.cross(f)
cam.matrix_world = Matrix(((r.x, u.x, -f.x, eye.x), (r.y, u.y, -f.y, eye.y),
                           (r.z, u.z, -f.z, eye.z), (0, 0, 0, 1)))
# Near/far around the scene (Freestyle culls nothing by them here).
corners = [o.matrix_world @ Vector(c) for o in scene.objects if o.type == "MESH" for c in o.bound_box]
dists = [(c - eye).dot(f) for c in corners]
cam_data.clip_start = max(min(dists) * 0.5, 1e-4)
cam_data.clip_end = max(dists) * 2

rd = scene.render
rd.resolution_x, rd.resolution_y, rd.resolution_percentage = W, H, 100
rd.pixel_aspect_x = rd.pixel_aspect_y = 1
# Cycles with one sample: Freestyle needs a render engine, this is the cheapest one that runs
# headless (EEVEE needs an OpenGL context).
rd.engine = "CYCLES"
scene.cycles.samples = 1
scene.cycles.device = "CPU"
scene.cycles.use_denoising = False  # Debian's build has no OpenImageDenoise: it refuses to render
rd.use_freestyle = True
rd.line_thickness_mode = "ABSOLUTE"
rd.line_thickness = 1.0
base = os.path.splitext(out_svg)[0]
rd.filepath = base + "_"

vl = scene.view_layers[0]
vl.use_freestyle = True
vl.cycles.use_denoising = False
fs = vl.freestyle_settings
fs.mode = "EDITOR"
fs.crease_angle = math.radians(180.0 - crease)
for ls in list(fs.linesets):
    fs.linesets.remove(ls)
for name, kinds in (("contour", ("silhouette", "border", "contour", "external_contour",
                                 "material_boundary")), ("crease", ("crease",))):
    ls = fs.linesets.new(name)
    ls.select_by_visibility = True
    ls.visibility = "VISIBLE"
    ls.select_by_edge_types = True
    for k in ("silhouette", "border", "crease", "ridge_valley", "suggestive_contour",
              "material_boundary", "contour", "external_contour", "edge_mark"):
        setattr(ls, "select_" + k, k in kinds)
    ls.linestyle.color = (0, 0, 0)
    ls.linestyle.thickness = 1.0
scene.svg_export.use_svg_export = True
scene.svg_export.mode = "FRAME"

bpy.ops.render.render(write_still=False)
t_render = time.time()
written = rd.filepath + "{:04d}.svg".format(scene.frame_current)
os.replace(written, out_svg)
print("freestyle: import %.2f s, render+freestyle %.2f s" % (t_import - t0, t_render - t_import),
      file=sys.stderr)
