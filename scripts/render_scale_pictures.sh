#!/usr/bin/env bash
# README pictures of patterns at the artist's scale: presets on real assets
# from ../shared/eval-data, and the same bunny at two tessellations.
#   bash scripts/render_scale_pictures.sh [out-dir]   (default docs/scale)
# Needs Blender 3.4 (apt: blender, python3-numpy) and a release build.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${1:-docs/scale}
data=../shared/eval-data
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
command -v blender >/dev/null || { echo "ERROR: blender is not installed (apt-get install blender python3-numpy)" >&2; exit 1; }
cargo build --release --quiet
bin=target/release/crackle
# name input preset elevation azimuth [extra crack arguments...]
shot() {
    local name=$1 input=$2 preset=$3 elev=$4 azim=$5
    shift 5
    "$bin" -q crack "$input" "$tmp/$name.glb" --preset "$preset" "$@"
    "$bin" stats "$tmp/$name.glb" --input "$input" | sed "1s|.*|$name.glb ($preset on ${input##*/})|" > "$out/$name.txt"
    blender -b --factory-startup --python scripts/render_preset_pictures.py -- \
        "$tmp/$name.glb" "$out/$name.png" "$elev" "$azim" BLENDER_WORKBENCH auto 3.0 >/dev/null 2>&1
    echo "$name: $(grep cells "$out/$name.txt" | tr -s ' ')"
}
shot teapot-glaze "$data/obj/teapot/teapot.obj" glaze 25 30
shot spot-glaze "$data/obj/spot/spot_triangulated.obj" glaze 20 60
shot duck-glaze "$data/gltf/Duck/Duck.glb" glaze 20 40
shot bunny-3k-glaze "$data/obj/npm-bunny/bunny.obj" glaze 15 20 --cell-size-relative 0.05
shot bunny-69k-glaze "$data/obj/stanford-bunny/stanford-bunny.obj" glaze 15 20 --cell-size-relative 0.05
shot ground-mud fixtures/plate_jittered.obj mud 65 10
shot teapot-impact "$data/obj/teapot/teapot.obj" glass-impact 25 30
# The other presets on real assets (and the ground patch).
shot teapot-tree-rings "$data/obj/teapot/teapot.obj" tree-rings 25 30
shot bunny-wood-grain "$data/obj/npm-bunny/bunny.obj" wood-grain 15 20
shot spot-curvature "$data/obj/spot/spot_triangulated.obj" curvature 20 60
shot duck-texture-mask "$data/gltf/Duck/Duck.glb" texture-mask 20 40
shot spot-springs-glaze "$data/obj/spot/spot_triangulated.obj" springs-glaze 20 60
shot teapot-impact-snapped "$data/obj/teapot/teapot.obj" impact-snapped 25 30
shot ground-mud-jagged fixtures/plate_jittered.obj mud-jagged 65 10
shot ground-springs-mud fixtures/plate_jittered.obj springs-mud 65 10
