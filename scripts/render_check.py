# Does a cracked output show its cracks in Blender? Renders the uncracked
# input and the output from the same camera (Workbench, textures shown, as
# an artist's solid view with textures), and checks that
#   - at least MIN_CHANGED of the pixels change, and
#   - at least MIN_NEAR of the changed pixels lie within NEAR_PX pixels of
#     the output's cracks: its crack lines (its LINES primitive, projected,
#     hidden parts removed by ray casts) and its visible gaps (the faces of
#     the crack_wall material: a gap many pixels wide is the crack too,
#     while its line runs along its middle). The share near the lines
#     alone is printed as near_lines.
# Prints one JSON line; exit status 1 when a check fails.
#
# Blender 3.4 (apt):  blender -b --factory-startup --python scripts/render_check.py -- IN OUT PREFIX [ENGINE]
# Blender 5.0 (PyPI bpy):  tools/bpy5/bin/python scripts/render_check.py IN OUT PREFIX [ENGINE]
# ENGINE: WORKBENCH (default: solid view with textures, base colour only) or
# EEVEE (material preview: normal and occlusion maps shade too).
# PREFIX names the renders (PREFIX-input.png, PREFIX-output.png, and
# PREFIX-gaps.png when the output has walls) and the
# picture of the difference (PREFIX-diff.png: changed pixels near crack
# lines red, changed pixels away from them yellow, crack lines blue).
import json, math, sys

import numpy

if not hasattr(numpy, "bool"):
    numpy.bool = bool  # the Blender 3.4 glTF importer still uses numpy.bool
import bpy, mathutils
from bpy_extras.object_utils import world_to_camera_view

MIN_CHANGED = 0.005
MIN_NEAR = 0.9
NEAR_PX = 4
WALL = "crack_wall"  # the material of the gaps' side walls
THRESHOLD = 0.08  # a pixel changes when a channel moves by more than this
W, H = 800, 600

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
src, out, prefix = argv[0], argv[1], argv[2]
ENGINE = argv[3] if len(argv) > 3 else "WORKBENCH"
version = bpy.app.version


def load(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.lower().endswith(".obj"):
        if version >= (4, 0, 0):
            bpy.ops.wm.obj_import(filepath=path)
        else:
            bpy.ops.import_scene.obj(filepath=path)
    else:
        bpy.ops.import_scene.gltf(filepath=path)
    return [o for o in bpy.context.scene.objects if o.type == "MESH"]


def bounds(objs):
    pts = [o.matrix_world @ mathutils.Vector(c) for o in objs for c in o.bound_box]
    lo = mathutils.Vector([min(p[i] for p in pts) for i in range(3)])
    hi = mathutils.Vector([max(p[i] for p in pts) for i in range(3)])
    return (lo + hi) / 2, (hi - lo).length / 2


def workbench_shading(scene, light, color_type):
    """Workbench's lighting and colour source, without shadows or cavity."""
    sh = scene.display.shading
    sh.light = light
    sh.color_type = color_type
    sh.show_shadows = False
    sh.show_cavity = False


def render(path, centre, radius):
    scene = bpy.context.scene
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    e, a = math.radians(25), math.radians(35)
    d = 2.6 * radius
    cam.location = centre + mathutils.Vector(
        (d * math.cos(e) * math.sin(a), -d * math.cos(e) * math.cos(a), d * math.sin(e)))
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 50
    cam.data.clip_start = radius * 1e-3
    cam.data.clip_end = radius * 100
    scene.camera = cam
    world = bpy.data.worlds.new("w")
    scene.world = world
    world.color = (0.8, 0.8, 0.85)  # Workbench background
    if ENGINE == "EEVEE":
        # Material preview: normal maps and lighting (Blender 5.0 calls it
        # BLENDER_EEVEE again after 4.2's BLENDER_EEVEE_NEXT).
        names = [e.identifier for e in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items]
        scene.render.engine = next(n for n in ("BLENDER_EEVEE_NEXT", "BLENDER_EEVEE") if n in names)
        scene.eevee.taa_render_samples = 8
        world.use_nodes = True
        world.node_tree.nodes["Background"].inputs[0].default_value = (0.8, 0.8, 0.85, 1)
        world.node_tree.nodes["Background"].inputs[1].default_value = 0.8
        sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
        sun.data.energy = 3.0
        sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(30))
        scene.collection.objects.link(sun)
    else:
        scene.render.engine = "BLENDER_WORKBENCH"
    workbench_shading(scene, "STUDIO", "TEXTURE")
    scene.render.resolution_x = W
    scene.render.resolution_y = H
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return cam


def pixels(path):
    img = bpy.data.images.load(path)
    px = numpy.array(img.pixels[:], dtype=numpy.float32).reshape(img.size[1], img.size[0], 4)
    return px[::-1, :, :3]  # row 0 at the top


def crack_line_mask(objs, cam):
    """Visible crack-line pixels (loose edges of the imported output)."""
    scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mask = numpy.zeros((H, W), dtype=bool)
    origin = cam.matrix_world.translation
    _, radius = bounds(objs)
    tol = 2e-3 * radius
    samples = 0
    for o in objs:
        me = o.data
        in_face = {k for p in me.polygons for k in p.edge_keys}
        for e in me.edges:
            if e.key in in_face:
                continue
            a = o.matrix_world @ me.vertices[e.vertices[0]].co
            b = o.matrix_world @ me.vertices[e.vertices[1]].co
            pa = world_to_camera_view(scene, cam, a)
            pb = world_to_camera_view(scene, cam, b)
            n = max(2, int(max(abs(pa.x - pb.x) * W, abs(pa.y - pb.y) * H) * 2) + 1)
            for k in range(n):
                t = k / (n - 1)
                p = a.lerp(b, t)
                q = pa.lerp(pb, t)
                x, y = int(q.x * W), int((1 - q.y) * H)
                if not (0 <= x < W and 0 <= y < H) or q.z <= 0:
                    continue
                ray = p - origin
                dist = ray.length
                hit, loc, *_ = scene.ray_cast(depsgraph, origin, ray.normalized(), distance=dist + tol)
                samples += 1
                if hit and (loc - origin).length < dist - tol:
                    continue  # hidden behind the surface
                mask[y, x] = True
    return mask, samples


def gap_mask(cam, path):
    """Visible gap pixels: the faces of the wall material (WALL), rendered
    flat white on black (Workbench, material colours). A gap wider than a
    few pixels is part of its crack, whose line runs along its middle."""
    scene = bpy.context.scene
    scene.camera = cam
    scene.render.engine = "BLENDER_WORKBENCH"
    workbench_shading(scene, "FLAT", "MATERIAL")
    scene.world.color = (0.0, 0.0, 0.0)
    scene.view_settings.view_transform = "Standard"
    walls = 0
    for m in bpy.data.materials:
        wall = m.name == WALL or m.name.startswith(WALL + ".")
        walls += wall
        m.diffuse_color = (1.0, 1.0, 1.0, 1.0) if wall else (0.0, 0.0, 0.0, 1.0)
    if not walls:
        return numpy.zeros((H, W), dtype=bool)
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    return pixels(path)[..., 0] > 0.5


def grow(mask, r):
    out = mask.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            if dx * dx + dy * dy > r * r:
                continue
            shifted = numpy.zeros_like(mask)
            ys = slice(max(dy, 0), H + min(dy, 0))
            yd = slice(max(-dy, 0), H + min(-dy, 0))
            xs = slice(max(dx, 0), W + min(dx, 0))
            xd = slice(max(-dx, 0), W + min(-dx, 0))
            shifted[yd, xd] = mask[ys, xs]
            out |= shifted
    return out


objs = load(src)
centre, radius = bounds(objs)
render(prefix + "-input.png", centre, radius)
objs = load(out)
cam = render(prefix + "-output.png", centre, radius)
engine = bpy.context.scene.render.engine
lines, samples = crack_line_mask(objs, cam)
a = pixels(prefix + "-input.png")
b = pixels(prefix + "-output.png")
changed = numpy.abs(a - b).max(axis=2) > THRESHOLD
gaps = gap_mask(cam, prefix + "-gaps.png")
near = grow(lines | gaps, NEAR_PX)
near_lines = grow(lines, NEAR_PX)
n_changed = int(changed.sum())
frac_changed = n_changed / (W * H)
frac_near = float((changed & near).sum()) / max(n_changed, 1)
frac_near_lines = float((changed & near_lines).sum()) / max(n_changed, 1)
# The difference as a picture: changed pixels red, crack lines blue.
diff = numpy.ones((H, W, 4), dtype=numpy.float32)
diff[..., :3] = 0.5 * b
diff[changed & near] = [1.0, 0.1, 0.1, 1.0]
diff[changed & ~near] = [1.0, 0.9, 0.0, 1.0]
diff[lines & ~changed] = [0.1, 0.2, 1.0, 1.0]
img = bpy.data.images.new("diff", W, H)
img.pixels[:] = diff[::-1].ravel()
img.filepath_raw = prefix + "-diff.png"
img.file_format = "PNG"
img.save()
ok = frac_changed >= MIN_CHANGED and frac_near >= MIN_NEAR
print("RENDER_CHECK " + json.dumps({
    "blender": ".".join(map(str, version)),
    "engine": engine,
    "input": src,
    "output": out,
    "changed": round(frac_changed, 5),
    "near_cracks": round(frac_near, 4),
    "near_lines": round(frac_near_lines, 4),
    "line_pixels": int(lines.sum()),
    "gap_pixels": int(gaps.sum()),
    "line_samples": samples,
    "ok": ok,
}))
sys.exit(0 if ok else 1)
