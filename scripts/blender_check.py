# Check that Blender 3.4 imports a crackle glTF/GLB cleanly:
#   blender -b --factory-startup --python scripts/blender_check.py -- in.glb [in2.glb ...]
# For each file prints the imported mesh objects, the material names, the
# number of faces per material, the number of loose edges (glTF LINES import
# as loose edges) and the number of faces with area < 1e-12.
# Exits with status 1 if an import fails or imports no mesh.
import sys, traceback
import numpy
numpy.bool = bool  # the Blender 3.4 glTF importer still uses numpy.bool
import bpy

TINY = 1e-12
argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not argv:
    print("usage: blender -b --factory-startup --python scripts/blender_check.py -- in.glb [...]")
    sys.exit(2)

failed = False
for src in argv:
    print("FILE", src)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    try:
        res = bpy.ops.import_scene.gltf(filepath=src)
    except Exception:
        traceback.print_exc()
        print("  IMPORT FAILED")
        failed = True
        continue
    if "FINISHED" not in res:
        print("  IMPORT FAILED", res)
        failed = True
        continue
    objs = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    if not objs:
        print("  IMPORT FAILED: no mesh objects")
        failed = True
        continue
    total_faces = total_tiny = 0
    for o in objs:
        me = o.data
        names = [s.material.name if s.material else "<none>" for s in o.material_slots] or ["<none>"]
        print("  OBJECT", o.name, "verts", len(me.vertices), "edges", len(me.edges), "faces", len(me.polygons))
        print("    materials", names)
        per = {}
        tiny = {}
        for p in me.polygons:
            i = p.material_index if p.material_index < len(names) else 0
            per[names[i]] = per.get(names[i], 0) + 1
            if p.area < TINY:
                tiny[names[i]] = tiny.get(names[i], 0) + 1
        for n in names:
            print("    faces %-14s %6d  (area < 1e-12: %d)" % (n, per.get(n, 0), tiny.get(n, 0)))
        in_face = {k for p in me.polygons for k in p.edge_keys}
        loose = sum(1 for e in me.edges if e.key not in in_face)
        print("    loose edges (glTF LINES)", loose)
        total_faces += len(me.polygons)
        total_tiny += sum(tiny.values())
    mats = sorted({s.material.name for o in objs for s in o.material_slots if s.material})
    print("  MATERIALS", mats)
    print("  TOTAL faces", total_faces, "faces with area < 1e-12:", total_tiny)

sys.exit(1 if failed else 0)
