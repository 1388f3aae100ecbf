# Render small README pictures of crackle outputs (Blender 3.4 headless).
#   blender -b --factory-startup --python scripts/render_preset_pictures.py -- \
#       in.glb out.png [elevation_deg] [azimuth_deg] [engine] [lines] [distance]
# engine: BLENDER_WORKBENCH (default, cheapest; works headless through
#         surfaceless EGL), BLENDER_EEVEE or CYCLES (CPU, low samples).
# lines:  auto (default) | on | off.  glTF LINES primitives (the crack_lines
#         material) import as loose edges, which no render engine draws. With
#         "on" they are copied into a separate object, converted to a curve and
#         given a small bevel so they show up as thin dark tubes. "auto" does
#         this only when the mesh has no crack_wall faces (i.e. when the cracks
#         are not already open gaps).
# distance: camera distance in units of the bounding-box half-diagonal (3.0).
# Based on scripts/render_preview.py; smaller image (640x400), fewer samples.
import sys, math
import numpy
numpy.bool = bool  # the Blender 3.4 glTF importer still uses numpy.bool
import bpy, mathutils

argv = sys.argv[sys.argv.index("--") + 1:]
src, out = argv[0], argv[1]
elev = float(argv[2]) if len(argv) > 2 else 50.0
azim = float(argv[3]) if len(argv) > 3 else 30.0
engine = argv[4] if len(argv) > 4 else "BLENDER_WORKBENCH"
lines = argv[5] if len(argv) > 5 else "auto"
dist = float(argv[6]) if len(argv) > 6 else 3.0

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=src)
scene = bpy.context.scene
objs = [o for o in scene.objects if o.type == "MESH"]
mats = sorted({s.material.name for o in objs for s in o.material_slots if s.material})
print("MATERIALS", mats)

# Bounds (of the imported meshes only)
pts = [o.matrix_world @ mathutils.Vector(c) for o in objs for c in o.bound_box]
lo = mathutils.Vector([min(p[i] for p in pts) for i in range(3)])
hi = mathutils.Vector([max(p[i] for p in pts) for i in range(3)])
c = (lo + hi) / 2
r = (hi - lo).length / 2

# Crack lines -> thin tubes
has_walls = "crack_wall" in mats
draw_lines = lines == "on" or (lines == "auto" and not has_walls)
if draw_lines:
    line_mat = bpy.data.materials.new("crack_lines_tube")
    line_mat.diffuse_color = (0.02, 0.02, 0.02, 1.0)  # Workbench uses this
    line_mat.use_nodes = True
    bsdf = line_mat.node_tree.nodes.get("Principled BSDF")
    if bsdf:
        bsdf.inputs["Base Color"].default_value = (0.02, 0.02, 0.02, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.8
    radius = 0.0022 * (hi - lo).length
    for o in objs:
        me = o.data
        in_face = {k for p in me.polygons for k in p.edge_keys}
        loose = [e.vertices[:] for e in me.edges if e.key not in in_face]
        if not loose:
            continue
        used = sorted({v for e in loose for v in e})
        remap = {v: i for i, v in enumerate(used)}
        lme = bpy.data.meshes.new(o.name + "_lines")
        lme.from_pydata([o.matrix_world @ me.vertices[v].co for v in used],
                        [(remap[a], remap[b]) for a, b in loose], [])
        lob = bpy.data.objects.new(o.name + "_lines", lme)
        scene.collection.objects.link(lob)
        bpy.ops.object.select_all(action="DESELECT")
        lob.select_set(True)
        bpy.context.view_layer.objects.active = lob
        bpy.ops.object.convert(target="CURVE")
        lob.data.bevel_depth = radius
        lob.data.bevel_resolution = 1
        lob.data.materials.clear()
        lob.data.materials.append(line_mat)
        print("LINES", o.name, len(loose), "edges -> tube radius", round(radius, 5))

cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
scene.collection.objects.link(cam)
e, a = math.radians(elev), math.radians(azim)
d = dist * r
cam.location = c + mathutils.Vector((d * math.cos(e) * math.sin(a), -d * math.cos(e) * math.cos(a), d * math.sin(e)))
cam.rotation_euler = (c - cam.location).to_track_quat("-Z", "Y").to_euler()
cam.data.lens = 50
scene.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 3.0
sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
scene.collection.objects.link(sun)
world = bpy.data.worlds.new("w"); scene.world = world
world.color = (0.8, 0.8, 0.85)  # Workbench background
world.use_nodes = True
world.node_tree.nodes["Background"].inputs[0].default_value = (0.8, 0.8, 0.85, 1)
world.node_tree.nodes["Background"].inputs[1].default_value = 0.6

scene.render.engine = engine
if engine == "CYCLES":
    scene.cycles.samples = 16
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
elif engine == "BLENDER_EEVEE":
    scene.eevee.taa_render_samples = 16
elif engine == "BLENDER_WORKBENCH":
    sh = scene.display.shading
    sh.light = "STUDIO"
    sh.color_type = "MATERIAL"
    sh.show_shadows = True
    sh.shadow_intensity = 0.4
    sh.show_cavity = True
    sh.cavity_type = "WORLD"
scene.render.resolution_x = 640
scene.render.resolution_y = 400
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.render.image_settings.compression = 100
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
