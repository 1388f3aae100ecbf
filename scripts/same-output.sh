#!/usr/bin/env bash
# Outputs of every preset on the fixture its description names and on three
# eval-data meshes, plus convert, stats, diff, --frames and batch, written to
# OUT_DIR. Run it before and after a change that must not change behaviour and
# compare the two folders with `diff -r` (or `cmp` file by file).
# Usage: scripts/same-output.sh OUT_DIR [crackle binary]
set -euo pipefail
cd "$(dirname "$0")/.."
out="$1"
bin="${2:-./target/release/crackle}"
data=../shared/eval-data
mkdir -p "$out"
run() { "$bin" "$@"; }
for p in glaze mud mud-jagged mud-aged glass-impact glass-tempered wood-grain tree-rings curvature texture-mask \
         springs-mud springs-glaze impact-snapped; do
  fixture=$(run presets | awk -v p="$p" '$1==p' | sed -E 's/.*try it on (fixtures\/[a-z_]+\.obj).*/\1/')
  run crack "$fixture" "$out/$p.glb" --preset "$p" -q --report "$out/$p.report.json"
done
run crack "$data/obj/spot/spot_triangulated.obj" "$out/spot-glaze.gltf" --preset glaze -q --report "$out/spot-glaze.report.json"
run crack "$data/gltf/Duck/Duck.glb" "$out/duck-mud.glb" --preset mud -q --split-islands
run crack "$data/derived/DamagedHelmet.glb" "$out/helmet-wood.glb" --preset wood-grain -q
run crack fixtures/icosphere.obj "$out/frames.glb" --preset glaze -q --frames 4 "$out/frames"
run convert "$data/obj/teapot/teapot.obj" "$out/teapot-convert.glb" -q
run stats "$out/glaze.glb" --json > "$out/glaze.stats.json"
run diff "$out/mud.glb" "$out/mud-jagged.glb" --json > "$out/diff.json" || true
run info "$data/gltf/Duck/Duck.glb" > "$out/duck.info.txt"
mkdir -p "$out/batch-in"
cp fixtures/icosphere.obj fixtures/torus.obj "$out/batch-in/"
run batch "$out/batch-in" --out "$out/batch-out" --preset glaze -q --report "$out/batch.report.json" || true
# Reports carry times; keep a copy without them for comparison.
for f in "$out"/*.json; do
  sed -E 's/"[a-z_]*(seconds|time_s|_ms|elapsed)[a-z_]*": *[-0-9.e]+/"<time>": 0/g' "$f" > "$f.notime"
done
