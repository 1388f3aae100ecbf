#!/usr/bin/env bash
# Speed and memory of the glaze preset on the benchmark meshes (release
# build): wall time, peak memory, per-stage seconds and the remeshed size.
#   scripts/bench_glaze.sh            # armadillo (86k), bunny (1.1M), teapot
#   scripts/bench_glaze.sh armadillo  # one of them
# `teapot` runs the Utah teapot at --cell-size-relative 0.02 (remeshed to
# about 280k triangles before cracking; the goal is under 20 s on 2 cores).
set -euo pipefail
cd "$(dirname "$0")/.."
data=../shared/eval-data
cargo build --release --quiet
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
run() {
  local name=$1 input=$2
  shift 2
  if [ ! -f "$input" ]; then
    echo "$name: $input is missing" >&2
    exit 1
  fi
  /usr/bin/time -v ./target/release/crackle crack "$input" "$out/$name.glb" \
    --preset glaze -q --report "$out/$name.json" "$@" 2> "$out/$name.time"
  python3 - "$name" "$out/$name.json" "$out/$name.time" <<'PY'
import json, re, sys
name, rep, tim = sys.argv[1:4]
r = json.load(open(rep))
t = open(tim).read()
wall = re.search(r"Elapsed \(wall clock\) time.*: (.*)", t).group(1)
rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1))
stages = ", ".join(f"{s['name']} {s['seconds']:.2f}" for s in r["stages"])
remeshed = [m["report"]["triangles"] for s in r["stages"] if s["name"] == "remesh"
            for m in s.get("meshes", []) if m["report"].get("remeshed")]
if remeshed:
    stages += (f"; remeshed from {sum(t[0] for t in remeshed)} "
               f"to {sum(t[1] for t in remeshed)} triangles")
print(f"{name}: {r['triangles']['before']} simulated triangles, {r['cracks']} cracks, "
      f"{r['relaxation_steps']} relaxation steps; wall {wall}, peak {rss / 1024:.0f} MiB; {stages}")
PY
}
want=${1:-all}
if [ "$want" = all ] || [ "$want" = armadillo ]; then
  run armadillo "$data/obj/armadillo/armadillo.obj"
fi
if [ "$want" = all ] || [ "$want" = bunny ]; then
  run bunny "$data/large/bunny_loop2_1.1M.glb"
fi
if [ "$want" = all ] || [ "$want" = teapot ]; then
  run teapot "$data/obj/teapot/teapot.obj" --cell-size-relative 0.02
fi
