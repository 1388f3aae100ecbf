#!/usr/bin/env bash
# Fuzz the OBJ, glTF and GLB readers in-process on mutants of the fixtures
# and ../shared/eval-data, each for SECONDS (default 60), then run the
# crackle binary on hostile asset folders for SECONDS (kind `hostile`:
# links into a victim folder, planted temporaries, copy rules, swapped
# files, sparse buffers, image bombs, many objects and primitives): counts
# per kind, and the reproducer of any failure in fuzz-out/.
# Usage: scripts/fuzz.sh [seconds] [seed]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
seed="${2:-1}"
target="${CARGO_TARGET_DIR:-target}"
cargo build --release --bin crackle --example fuzz
status=0
for kind in obj gltf glb hostile; do
  "$target/release/examples/fuzz" "$kind" "$seconds" "$seed" || status=1
done
exit $status
