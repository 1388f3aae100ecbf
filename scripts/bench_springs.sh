#!/usr/bin/env bash
# springs-mud on a 20,000-triangle jittered plate (100 x 100 cells), release
# build: wall time, peak memory, breaks and steps, at the preset's cell size
# and at a half, a quarter and an eighth of it (1.9k, 7.6k, 29k and 114k
# simulated triangles: the simulate stage's seconds per simulated triangle
# show how it scales).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 - "$work/plate.obj" <<'PY'
import random, sys
n = 100
random.seed(1)
with open(sys.argv[1], "w") as f:
    for j in range(n + 1):
        for i in range(n + 1):
            x, y = float(i), float(j)
            if 0 < i < n and 0 < j < n:
                x += random.uniform(-0.3, 0.3)
                y += random.uniform(-0.3, 0.3)
            f.write(f"v {x / n:.6f} {y / n:.6f} 0\n")
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i + 1
            b, c, d = a + 1, a + n + 1, a + n + 2
            f.write(f"f {a} {b} {d}\nf {a} {d} {c}\n")
PY
for cell in 0.2 0.1 0.05 0.025; do
/usr/bin/time -v ./target/release/crackle crack "$work/plate.obj" "$work/out.glb" \
    --preset springs-mud --cell-size-relative "$cell" -q --report "$work/r.json" 2> "$work/time"
python3 - "$work/r.json" "$work/time" "$cell" <<'PY'
import json, re, sys
r = json.load(open(sys.argv[1]))
t = open(sys.argv[2]).read()
m = r["meshes"][0]["report"]
wall = re.search(r"Elapsed \(wall clock\) time.*: (.*)", t).group(1)
rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1))
stages = ", ".join(f"{s['name']} {s['seconds']:.2f}" for s in r["stages"])
sim = next(s["seconds"] for s in r["stages"] if s["name"] == "simulate")
tris = m["triangles"][0]
print(f"springs-mud, cell {sys.argv[3]}, on a {r['triangles']['before']}-triangle plate "
      f"({tris} simulated): {r['cracks']} breaks, "
      f"{m['relax_steps']} steps of {m['stable_dt']:.3f}, stopped: {m['stopped']}; "
      f"wall {wall}, peak {rss / 1024:.0f} MiB; simulate {1e6 * sim / tris:.1f} us a simulated triangle; {stages}")
PY
done
