#!/usr/bin/env bash
# `crackle convert` side by side with the tools artists already use, in one
# run on one machine (release build), runs alternated:
#   - the 1.1M-triangle bunny GLB against `gltf-transform copy`
#     (npm @gltf-transform/cli, installed into tools/node_modules);
#   - the 496k-triangle ogre OBJ against trimesh's `load(process=False)` plus
#     GLB export (PyPI trimesh, installed into tools/bench-venv), timed inside
#     Python (its start-up and import are left out, in trimesh's favour).
# Prints each run's seconds and the ratio's range (peer over crackle).
#   scripts/bench_convert.sh [RUNS]      # default 5
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
data=../shared/eval-data
bunny=$data/large/bunny_loop2_1.1M.glb
ogre=$data/large/ogre_loop1_496k.obj
for f in "$bunny" "$ogre"; do
  [ -f "$f" ] || { echo "bench_convert: $f is missing" >&2; exit 1; }
done
die() { echo "bench_convert: ERROR: $*" >&2; exit 1; }
command -v npm >/dev/null || die "npm is not on PATH (apt-get install npm)"
command -v python3 >/dev/null || die "python3 is not on PATH"
gt=tools/node_modules/.bin/gltf-transform
if [ ! -x "$gt" ]; then
  npm install --prefix tools --no-save --silent @gltf-transform/cli@4.5.1 >&2 \
    || die "npm install @gltf-transform/cli failed"
fi
venv=tools/bench-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv" || die "python3 -m venv failed (apt-get install python3-venv)"
  "$venv/bin/pip" install -q trimesh==5.2.0 numpy || die "pip install trimesh failed"
fi
cargo build --release --quiet
crackle=${CARGO_TARGET_DIR:-target}/release/crackle
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
secs() { # command... -> wall seconds
  local t0 t1
  t0=$(date +%s.%N); "$@" > /dev/null; t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.3f}')"
}
ratios() { # name, then pairs "peer crackle" on stdin
  python3 -c "
import sys
name = sys.argv[1]
p = [tuple(map(float, l.split())) for l in sys.stdin if l.strip()]
r = sorted(a / b for a, b in p)
print(f'{name}: peer/crackle {r[len(r) // 2]:.2f}x (range {r[0]:.2f}-{r[-1]:.2f}, {len(r)} paired runs)')
" "$1"
}
echo "bunny 1.1M GLB: gltf-transform copy | crackle convert (s)"
for _ in $(seq "$runs"); do
  a=$(secs "$gt" copy "$bunny" "$out/gt.glb")
  b=$(secs "$crackle" convert -q "$bunny" "$out/c.glb")
  echo "$a $b"
done | tee "$out/bunny.txt"
ratios bunny < "$out/bunny.txt"
echo "ogre 496k OBJ: trimesh load+export (in Python) | crackle convert (s)"
for _ in $(seq "$runs"); do
  a=$("$venv/bin/python" -c "
import sys, time, trimesh
t = time.time()
trimesh.load(sys.argv[1], process=False).export(sys.argv[2])
print(f'{time.time() - t:.3f}')
" "$ogre" "$out/tm.glb")
  b=$(secs "$crackle" convert -q "$ogre" "$out/c.glb")
  echo "$a $b"
done | tee "$out/ogre.txt"
ratios ogre < "$out/ogre.txt"
