#!/usr/bin/env bash
# Do the cracks show in Blender and in a web viewer? Every built-in preset on
# its own fixture and on spot, the Duck and the DamagedHelmet
# (../shared/eval-data), rendered next to the uncracked input (as glTF, by
# `crackle convert`, so both go through the same importer) with the same
# camera in Blender 3.4 and Blender 5.0 (EEVEE, as the material preview;
# scripts/render_check.py) and in
# three.js' GLTFLoader in headless Chromium (scripts/web_check.mjs): at
# least 0.5% of the pixels must change, and at least 90% of the changed
# pixels must lie within 4 pixels of the projected crack lines.
#   bash scripts/render_check.sh [out-dir] [preset...]   (default out/render-check, all presets)
# Installs what it needs: Blender 3.4 and Chromium from apt (as root),
# Blender 5.0 as the PyPI module bpy in tools/bpy5 (Python 3.11), three and
# puppeteer-core from npm in tools/web. Prints one line per render and a
# summary; exits 1 when any check fails.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${1:-out/render-check}
shift || true
data=../shared/eval-data
mkdir -p "$out"

if ! command -v blender >/dev/null || ! python3 -c "import numpy" 2>/dev/null || ! command -v chromium >/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "installing Blender 3.4, numpy and Chromium from apt"
        apt-get install -y -q blender python3-numpy chromium >/dev/null
    else
        echo "ERROR: Blender 3.4 or Chromium is missing; as root: apt-get install blender python3-numpy chromium" >&2
        exit 1
    fi
fi
if [ ! -f tools/web/node_modules/three/package.json ] || [ ! -f tools/web/node_modules/puppeteer-core/package.json ]; then
    echo "installing three and puppeteer-core from npm into tools/web"
    mkdir -p tools/web
    (cd tools/web && { [ -f package.json ] || echo '{"private": true}' > package.json; } && npm install --silent three@0.171.0 puppeteer-core@24.43.1)
fi
if [ ! -x tools/bpy5/bin/python ] || ! tools/bpy5/bin/python -c "import bpy" 2>/dev/null; then
    py=$(command -v python3.11 || true)
    if [ -z "$py" ]; then
        echo "ERROR: Blender 5.0's Python module (bpy 5.0.1) needs Python 3.11 (python3.11 not found)" >&2
        exit 1
    fi
    echo "installing Blender 5.0 (PyPI bpy 5.0.1) into tools/bpy5"
    rm -rf tools/bpy5
    "$py" -m venv tools/bpy5
    tools/bpy5/bin/pip install -q bpy==5.0.1 numpy
fi
cargo build --release --quiet
bin=target/release/crackle

presets=("$@")
if [ ${#presets[@]} -eq 0 ]; then
    mapfile -t presets < <("$bin" presets | awk 'NF {print $1}')
fi
assets=("$data/obj/spot/spot_triangulated.obj" "$data/gltf/Duck/Duck.glb" "$data/gltf/DamagedHelmet/DamagedHelmet.gltf")
for a in "${assets[@]}"; do
    [ -f "$a" ] || { echo "ERROR: $a is missing (../shared/eval-data)" >&2; exit 1; }
done

pass=0
fail=0
failed=()
check() {
    local name=$1 input=$2 output=$3
    local line base ref
    # The uncracked input as glTF (crackle convert): every viewer then reads
    # input and output through the same importer and material model.
    base=$(basename "$input"); base=${base%.*}
    ref="$out/$base-reference.glb"
    [ -f "$ref" ] || "$bin" -q convert "$input" "$ref"
    for blender in 3.4 5.0; do
        if [ "$blender" = 3.4 ]; then
            line=$(blender -b --factory-startup --python scripts/render_check.py -- "$ref" "$output" "$out/$name-b34" EEVEE 2>&1 | grep '^RENDER_CHECK' || true)
        else
            line=$(tools/bpy5/bin/python scripts/render_check.py "$ref" "$output" "$out/$name-b50" EEVEE 2>&1 | grep '^RENDER_CHECK' || true)
        fi
        if [[ "$line" == *'"ok": true'* ]]; then
            pass=$((pass + 1))
        else
            fail=$((fail + 1))
            failed+=("$name (Blender $blender)")
        fi
        echo "$name Blender $blender: ${line#RENDER_CHECK }"
    done
    line=$(node scripts/web_check.mjs "$ref" "$output" "$out/$name" 2>&1 | grep '^WEB_CHECK' || true)
    if [[ "$line" == *'"ok":true'* ]]; then
        pass=$((pass + 1))
    else
        fail=$((fail + 1))
        failed+=("$name (three.js)")
    fi
    echo "$name three.js: ${line#WEB_CHECK }"
}

for preset in "${presets[@]}"; do
    # The ductile model tears solids apart rather than cracking a surface:
    # the crack-line pixel test does not apply (tests/ductile.rs checks it).
    [ "$preset" = tear ] && { echo "tear: skipped (no crack lines to compare with)"; continue; }
    fixture=$("$bin" presets | awk -v p="$preset" '$1 == p' | grep -o 'fixtures/[A-Za-z0-9_.-]*' | head -1)
    for input in "$fixture" "${assets[@]}"; do
        [ -n "$input" ] || continue
        base=$(basename "$input"); base=${base%.*}
        name="$preset-$base"
        # Smooth normals off: the reference keeps the input's own shading
        # (flat where it has no normals), and smooth shading would change
        # every pixel of such an input (tests/smooth_normals.rs checks it).
        if ! "$bin" -q crack "$input" "$out/$name.glb" --preset "$preset" --set post.smooth_angle=0 --report "$out/$name.json" 2>"$out/$name.err"; then
            fail=$((fail + 1))
            failed+=("$name (crack: $(head -c 300 "$out/$name.err"))")
            echo "$name: crack failed: $(head -c 300 "$out/$name.err")"
            continue
        fi
        check "$name" "$input" "$out/$name.glb"
    done
done
echo
echo "render checks: $pass passed, $fail failed"
for f in "${failed[@]}"; do echo "  FAILED: $f"; done
[ "$fail" -eq 0 ]
