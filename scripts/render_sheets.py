#!/usr/bin/env python3
"""Render the presets' contact sheets (docs/presets/assets/*.jpg), repeatably.

    python3 scripts/render_sheets.py WORK_DIR [--assets teapot,spot,ground,pane]
        [--jobs 2] [--out docs/presets/assets] [--render-only]

Cracks each asset with every preset at its defaults (`crackle crack IN
OUT.glb --preset P`), renders each output with Blender 3.4 headless
(scripts/render_preset_pictures.py: Workbench; EEVEE for the last three
tiles) from the camera recorded below for that asset, and lays the tiles out
four by four with their labels (a failed run is a red tile with the error's
first line). The ground patch and the pane are written by this script (the
ground: a regular 200x200 grid, 10 units, a 0.01 height grain from a fixed
seed, one diagonal per square, UVs; the pane: a 120x80 grid of 1.2 x 0.8,
jittered by 0.3 of a cell). Needs a release build (`cargo build --release`),
`blender` (3.4, Debian's) on PATH and Pillow. Each tile's crack and render
logs stay in WORK_DIR; `--render-only` renders the outputs already there
again (a camera change) without cracking.
"""
import concurrent.futures as cf
import os
import random
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "crackle")
RENDER = os.path.join(ROOT, "scripts", "render_preset_pictures.py")
FONT = os.path.join(ROOT, "assets", "fonts", "DejaVuSans.ttf")
DATA = os.path.join(ROOT, "..", "shared", "eval-data", "obj")

# The sixteen tiles: (label, preset, engine).
TILES = [
    ("glaze", "glaze", "BLENDER_WORKBENCH"),
    ("mud", "mud", "BLENDER_WORKBENCH"),
    ("mud-jagged", "mud-jagged", "BLENDER_WORKBENCH"),
    ("mud-aged", "mud-aged", "BLENDER_WORKBENCH"),
    ("glass-impact", "glass-impact", "BLENDER_WORKBENCH"),
    ("glass-tempered", "glass-tempered", "BLENDER_WORKBENCH"),
    ("wood-grain", "wood-grain", "BLENDER_WORKBENCH"),
    ("tree-rings", "tree-rings", "BLENDER_WORKBENCH"),
    ("curvature", "curvature", "BLENDER_WORKBENCH"),
    ("texture-mask", "texture-mask", "BLENDER_WORKBENCH"),
    ("springs-mud", "springs-mud", "BLENDER_WORKBENCH"),
    ("springs-glaze", "springs-glaze", "BLENDER_WORKBENCH"),
    ("impact-snapped", "impact-snapped", "BLENDER_WORKBENCH"),
    ("glaze (EEVEE)", "glaze", "BLENDER_EEVEE"),
    ("mud (EEVEE)", "mud", "BLENDER_EEVEE"),
    ("mud-aged (EEVEE)", "mud-aged", "BLENDER_EEVEE"),
]

# Per asset: the input and the camera (elevation, azimuth in degrees,
# distance in bounding-box half-diagonals; see render_preset_pictures.py).
ASSETS = {
    "teapot": (os.path.join(DATA, "teapot", "teapot.obj"), 25, 15, 2.6),
    "spot": (os.path.join(DATA, "spot", "spot_triangulated.obj"), 20, 120, 3.2),
    "ground": ("ground.obj", 60, 20, 2.0),
    "pane": ("pane.obj", 5, 0, 2.8),
}

W, H, HEADER, BAND = 480, 300, 70, 30


def ground_obj(path):
    """A regular 200x200 ground patch, 10 units, a 0.01 height grain, UVs."""
    n, size = 200, 10.0
    rng = random.Random(7)
    with open(path, "w") as f:
        f.write("# ground patch 200x200, 10 units, 0.01 height grain (seed 7)\n")
        for j in range(n + 1):
            for i in range(n + 1):
                x, z = size * i / n - size / 2, size * j / n - size / 2
                f.write(f"v {x:.6f} {0.01 * (rng.random() - 0.5):.6f} {z:.6f}\n")
        for j in range(n + 1):
            for i in range(n + 1):
                f.write(f"vt {i / n:.6f} {j / n:.6f}\n")
        write_faces(f, n, n, up=True)


def pane_obj(path):
    """A 120x80 grid pane of 1.2 x 0.8, interior vertices jittered by 0.3 of a cell."""
    nx, ny, sx, sy = 120, 80, 1.2, 0.8
    rng = random.Random(11)
    cx, cy = sx / nx, sy / ny
    with open(path, "w") as f:
        f.write("# pane 120x80, 1.2 x 0.8, jitter 0.3 (seed 11)\n")
        for j in range(ny + 1):
            for i in range(nx + 1):
                x, y = cx * i - sx / 2, cy * j - sy / 2
                if 0 < i < nx and 0 < j < ny:
                    x += 0.3 * cx * (2 * rng.random() - 1)
                    y += 0.3 * cy * (2 * rng.random() - 1)
                f.write(f"v {x:.6f} {y:.6f} 0\n")
        for j in range(ny + 1):
            for i in range(nx + 1):
                f.write(f"vt {i / nx:.6f} {j / ny:.6f}\n")
        write_faces(f, nx, ny)


def write_faces(f, nx, ny, up=False):
    """Two triangles per grid square, one diagonal; facing +z (the pane), or
    +y for a grid laid out in x and z (`up`: the ground faces the sky)."""
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i + 1
            b, c, d = a + 1, a + nx + 2, a + nx + 1
            if up:
                b, d = d, b
            f.write(f"f {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}\n")


RENDER_ONLY = "--render-only" in sys.argv


def tile(work, asset, k):
    """Crack and render tile `k` of `asset`: (png or None, error line, seconds)."""
    src, elev, azim, dist = ASSETS[asset]
    label, preset, engine = TILES[k]
    stem = os.path.join(work, f"{asset}-{k:02d}-{preset}")
    glb = os.path.join(work, f"{asset}-{preset}.glb")
    t0 = time.time()
    # The EEVEE tiles reuse the Workbench tile's output of the same preset.
    if RENDER_ONLY:
        if not os.path.exists(glb):
            return None, "no output to render", time.time() - t0
    elif not any(t[1] == preset for t in TILES[:k]):
        run = subprocess.run([BIN, "crack", src, glb, "--preset", preset, "-q"],
                             capture_output=True, text=True)
        open(stem + ".crack.log", "w").write(run.stdout + run.stderr)
        if run.returncode != 0:
            err = (run.stderr.strip().splitlines() or ["exit %d" % run.returncode])[-1]
            return None, err, time.time() - t0
    else:
        while not os.path.exists(glb + ".done") and not os.path.exists(glb + ".failed"):
            time.sleep(1)
        if os.path.exists(glb + ".failed"):
            return None, open(glb + ".failed").read(), time.time() - t0
    open(glb + ".done", "w").close()
    png = stem + ".png"
    run = subprocess.run(["blender", "-b", "--factory-startup", "--python", RENDER, "--",
                          glb, png, str(elev), str(azim), engine, "auto", str(dist)],
                         capture_output=True, text=True)
    open(stem + ".render.log", "w").write(run.stdout + run.stderr)
    if run.returncode != 0 or not os.path.exists(png):
        return None, "render failed (see %s.render.log)" % stem, time.time() - t0
    return png, "", time.time() - t0


def sheet(asset, results, out):
    from PIL import Image, ImageDraw, ImageFont
    img = Image.new("RGB", (4 * W, HEADER + 4 * (H + BAND)), "white")
    draw = ImageDraw.Draw(img)
    big, small = ImageFont.truetype(FONT, 30), ImageFont.truetype(FONT, 22)
    draw.text((10, 12), f"crackle presets on {asset}  (Blender 3.4, Workbench unless marked)",
              fill="black", font=big)
    for k, (png, err) in enumerate(results):
        x, y = (k % 4) * W, HEADER + (k // 4) * (H + BAND)
        draw.text((x + 8, y + 3), TILES[k][0], fill="black", font=small)
        if png:
            img.paste(Image.open(png).convert("RGB").resize((W, H), Image.LANCZOS), (x, y + BAND))
        else:
            draw.rectangle([x + 1, y + BAND, x + W - 2, y + BAND + H - 1], fill=(230, 200, 200))
            # The error's last clause: what is wrong, not the file's path.
            words, lines = ("FAILED: " + err.rsplit(": ", 1)[-1]).split(), [""]
            for w in words:
                if len(lines[-1]) + len(w) > 36:
                    lines.append("")
                lines[-1] += w + " "
            for i, line in enumerate(lines[:4]):
                draw.text((x + 12, y + BAND + H // 2 - 40 + 28 * i), line, fill="black", font=small)
    img.save(out, quality=88)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    work = os.path.abspath(sys.argv[1])
    opt = lambda name, default: sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default
    assets = opt("--assets", ",".join(ASSETS)).split(",")
    jobs = int(opt("--jobs", "2"))
    out = opt("--out", os.path.join(ROOT, "docs", "presets", "assets"))
    os.makedirs(work, exist_ok=True)
    if not os.path.exists(BIN):
        sys.exit(f"{BIN} is missing: cargo build --release")
    for asset in assets:
        src = ASSETS[asset][0]
        if not os.path.isabs(src):
            path = os.path.join(work, src)
            (ground_obj if asset == "ground" else pane_obj)(path)
            ASSETS[asset] = (path,) + ASSETS[asset][1:]
        elif not os.path.exists(src):
            sys.exit(f"{asset}: {src} is missing (../shared/eval-data)")
    for asset in assets:
        for t in TILES:
            for mark in (".done", ".failed"):
                stale = os.path.join(work, f"{asset}-{t[1]}.glb{mark}")
                if os.path.exists(stale):
                    os.remove(stale)
        with cf.ThreadPoolExecutor(jobs) as pool:
            futures = [pool.submit(tile, work, asset, k) for k in range(len(TILES))]
            results = []
            for k, fut in enumerate(futures):
                png, err, secs = fut.result()
                glb = os.path.join(work, f"{asset}-{TILES[k][1]}.glb")
                if err and not os.path.exists(glb + ".done"):
                    open(glb + ".failed", "w").write(err)
                print(f"{asset:7s} {TILES[k][0]:18s} {secs:6.1f} s  {err or 'ok'}", flush=True)
                results.append((png, err))
        path = os.path.join(out, f"{asset}.jpg")
        sheet(asset, results, path)
        print("wrote", path, flush=True)


if __name__ == "__main__":
    main()
