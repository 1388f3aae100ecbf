#!/usr/bin/env bash
# Fuzz the OBJ, glTF and GLB readers in-process on mutants of the fixtures
# and ../shared/eval-data, each for SECONDS (default 60): counts per reader,
# and the reproducer of any panic, hang or memory overrun in fuzz-out/.
# Usage: scripts/fuzz.sh [seconds] [seed]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
seed="${2:-1}"
cargo build --release --example fuzz
status=0
for kind in obj gltf glb; do
  ./target/release/examples/fuzz "$kind" "$seconds" "$seed" || status=1
done
exit $status
