# Render a glTF/GLB for a quick look (Blender 3.4 headless, Cycles on the CPU):
#   blender -b --factory-startup --python scripts/render_preview.py -- in.glb out.png [elevation_deg] [azimuth_deg]
# Prints the materials it imported. Needs python3-numpy (numpy.bool alias set below).
import sys, math
import numpy
numpy.bool = bool
import bpy, mathutils
argv = sys.argv[sys.argv.index("--") + 1:]
src, out = argv[0], argv[1]
elev = float(argv[2]) if len(argv) > 2 else 50.0
azim = float(argv[3]) if len(argv) > 3 else 30.0
engine = argv[4] if len(argv) > 4 else "CYCLES"
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=src)
objs = [o for o in bpy.context.scene.objects if o.type == "MESH"]
mats = sorted({s.material.name for o in objs for s in o.material_slots if s.material})
print("MATERIALS", mats)
# Bounds
pts = [o.matrix_world @ mathutils.Vector(c) for o in objs for c in o.bound_box]
lo = mathutils.Vector([min(p[i] for p in pts) for i in range(3)])
hi = mathutils.Vector([max(p[i] for p in pts) for i in range(3)])
c = (lo + hi) / 2
r = (hi - lo).length / 2
scene = bpy.context.scene
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
scene.collection.objects.link(cam)
e, a = math.radians(elev), math.radians(azim)
d = 2.6 * r
cam.location = c + mathutils.Vector((d * math.cos(e) * math.sin(a), -d * math.cos(e) * math.cos(a), d * math.sin(e)))
cam.rotation_euler = (c - cam.location).to_track_quat("-Z", "Y").to_euler()
cam.data.lens = 50
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 3.0
sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("w"); scene.world = world
world.use_nodes = True
world.node_tree.nodes["Background"].inputs[0].default_value = (0.8, 0.8, 0.85, 1)
world.node_tree.nodes["Background"].inputs[1].default_value = 0.6
scene.render.engine = engine
if engine == "CYCLES":
    scene.cycles.samples = 24
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
scene.render.resolution_x = 640
scene.render.resolution_y = 480
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
