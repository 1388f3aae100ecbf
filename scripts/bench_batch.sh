#!/usr/bin/env bash
# Batch speed-up across assets: 40 fixture-sized assets (copies of the
# project's OBJ fixtures) cracked with `crackle batch --preset mud` at -j1 and
# -j2 (release build), each the least of 3 runs (--force, so every run does
# all the work). Prints both times and the ratio.
#   scripts/bench_batch.sh [runs]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
cargo build --release --quiet
bin=$PWD/target/release/crackle
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fixtures=(plate_jittered.obj icosphere.obj torus.obj bumps.obj cube.obj)
for i in $(seq 0 39); do
    f=${fixtures[$((i % ${#fixtures[@]}))]}
    d="$work/lib/set$((i / 10))"
    mkdir -p "$d"
    cp "fixtures/$f" "$d/a$i.obj"
    if [ "$f" = cube.obj ]; then
        cp fixtures/cube.mtl "fixtures/cube texture.png" "$d/"
    fi
done
best() {
    local jobs=$1 best=""
    for _ in $(seq "$runs"); do
        local t0 t1 s
        t0=$(date +%s.%N)
        "$bin" batch "$work/lib" -r --out "$work/out$jobs" --preset mud -j "$jobs" --force -q
        t1=$(date +%s.%N)
        s=$(echo "$t1 - $t0" | bc -l)
        if [ -z "$best" ] || [ "$(echo "$s < $best" | bc -l)" = 1 ]; then best=$s; fi
    done
    echo "$best"
}
j1=$(best 1)
j2=$(best 2)
cmp -s <(cd "$work/out1" && find . -name '*.glb' -exec sha256sum {} + | sort) \
       <(cd "$work/out2" && find . -name '*.glb' -exec sha256sum {} + | sort) \
    || { echo "ERROR: -j1 and -j2 outputs differ" >&2; exit 1; }
printf 'batch of 40 assets (mud): -j1 %.2f s, -j2 %.2f s, speed-up %.2fx (outputs identical)\n' \
    "$j1" "$j2" "$(echo "$j1 / $j2" | bc -l)"
