#!/usr/bin/env bash
# Speed and memory of the glaze preset on the two benchmark meshes of
# issue 6 (release build): wall time, peak memory and per-stage seconds.
#   scripts/bench_glaze.sh            # armadillo (86k) and bunny (1.1M)
#   scripts/bench_glaze.sh armadillo  # one of them
set -euo pipefail
cd "$(dirname "$0")/.."
data=../shared/eval-data
cargo build --release --quiet
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
run() {
  local name=$1 input=$2
  if [ ! -f "$input" ]; then
    echo "$name: $input is missing" >&2
    exit 1
  fi
  /usr/bin/time -v ./target/release/crackle crack "$input" "$out/$name.glb" \
    --preset glaze -q --report "$out/$name.json" 2> "$out/$name.time"
  python3 - "$name" "$out/$name.json" "$out/$name.time" <<'PY'
import json, re, sys
name, rep, tim = sys.argv[1:4]
r = json.load(open(rep))
t = open(tim).read()
wall = re.search(r"Elapsed \(wall clock\) time.*: (.*)", t).group(1)
rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1))
stages = ", ".join(f"{s['name']} {s['seconds']:.2f}" for s in r["stages"])
print(f"{name}: {r['triangles']['before']} triangles, {r['cracks']} cracks, "
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
