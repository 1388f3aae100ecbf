#!/usr/bin/env python3
"""Does the input leak into the pattern, and does the artist's mesh come back?

    python3 scripts/pattern_check.py OUT_DIR [--presets glaze,mud] [--seeds 1] [--meshes a,b]

Cracks the meshes a DCC tool makes (regular plates, a latitude-longitude
sphere, an icosphere, a jittered plate: written by `measure shapes`) and the
evaluation corpus' Stanford bunny and teapot with each preset, then measures
every output with the independent measure (examples/measure.rs, which shares
no code with `crackle stats`): the share of crack length on the input's
edges (at rest), the orientation of the cracks against the grid's rows
(plates, and the sphere's meridians and parallels), open tips, crack ends
that stop short of another crack (within 5% of a cell), and the triangles
written against the input's. One line per output, and a JSON file of all.
Needs a release build (`cargo build --release --examples`).
"""
import json, os, subprocess, sys, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "crackle")
MEASURE = os.path.join(ROOT, "target", "release", "examples", "measure")
DATA = os.path.join(ROOT, "..", "shared", "eval-data")


def arg(name, default):
    if name in sys.argv:
        return sys.argv[sys.argv.index(name) + 1]
    return default


def main():
    if len(sys.argv) < 2 or sys.argv[1].startswith("--"):
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    shapes = os.path.join(out, "shapes")
    os.makedirs(shapes, exist_ok=True)
    subprocess.run([MEASURE, "shapes", shapes], check=True, stdout=subprocess.DEVNULL)
    meshes = {
        "regular_160": (os.path.join(shapes, "regular_160.obj"), "plate"),
        "regular_320": (os.path.join(shapes, "regular_320.obj"), "plate"),
        "latlong_400x200": (os.path.join(shapes, "latlong_400x200.obj"), "latlong"),
        "icosphere_6": (os.path.join(shapes, "icosphere_6.obj"), "none"),
        "jittered_160": (os.path.join(shapes, "jittered_160.obj"), "plate"),
        "disc_160": (os.path.join(shapes, "disc_160.obj"), "disc"),
        "stanford_bunny": (os.path.join(DATA, "obj/stanford-bunny/stanford-bunny.obj"), "none"),
        "teapot": (os.path.join(DATA, "obj/teapot/teapot.obj"), "none"),
    }
    only = arg("--meshes", None)
    if only:
        meshes = {k: v for k, v in meshes.items() if k in only.split(",")}
    presets = arg("--presets", "glaze,mud").split(",")
    seeds = int(arg("--seeds", "1"))
    rows = []
    print(f"{'preset':<12} {'mesh':<16} {'seed':>4} {'tris in':>8} {'tris out':>8} {'on edges':>8} "
          f"{'bins max dev':>12} {'axis':>6} {'tips':>5} {'loose':>5} {'s':>6}")
    for preset in presets:
        for name, (path, frame) in meshes.items():
            if not os.path.exists(path):
                print(f"SKIP {name}: {path} missing")
                continue
            for seed in range(1, seeds + 1):
                glb = os.path.join(out, f"{preset}-{name}-{seed}.glb")
                rep = glb[:-4] + ".json"
                t = time.time()
                subprocess.run([BIN, "-q", "crack", path, glb, "--preset", preset, "--seed", str(seed),
                                "--report", rep], check=True)
                seconds = time.time() - t
                r = json.load(open(rep))
                cell = r["meshes"][0]["report"].get("cell_size")
                if not cell:
                    # The spring and snapping models: edges of an eighth of the
                    # preset's fraction of the diagonal.
                    remesh = [s for s in r["stages"] if s["name"] == "remesh"]
                    cell = 8 * remesh[0]["meshes"][0]["target_edge"] if remesh else None
                cmd = [MEASURE, glb, "--input", path, "--frame", frame]
                if cell:
                    cmd += ["--cell", str(cell)]
                m = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
                bins = m.get("orientation_bins")
                dev = max(abs(6 * b - 1) for b in bins) if bins else None
                curved = frame not in ("plate", "disc")
                tips = m["open_tips_curved"] if curved else m["open_tips"]
                loose = m["loose_ends_curved"] if curved else m["loose_ends"]
                row = {"preset": preset, "mesh": name, "seed": seed,
                       "triangles": [m["input_triangles"], m["output_triangles"]],
                       "simulated_triangles": r["triangles"]["after"], "edge_share": m["edge_share"], "orientation_bins": bins,
                       "max_bin_deviation": dev, "axis_share": m.get("axis_share"), "open_tips": tips,
                       "loose_ends": loose, "seconds": seconds, "cell_size": cell}
                rows.append(row)
                d = f"{dev:.3f}" if dev is not None else "-"
                ax = f"{m['axis_share']:.3f}" if m.get("axis_share") is not None else "-"
                print(f"{preset:<12} {name:<16} {seed:>4} {m['input_triangles']:>8} {m['output_triangles']:>8} "
                      f"{m['edge_share']:>8.4f} {d:>12} {ax:>6} {tips:>5} {loose:>5} {seconds:>6.1f}", flush=True)
    json.dump(rows, open(os.path.join(out, "pattern_check.json"), "w"), indent=1)


if __name__ == "__main__":
    main()
