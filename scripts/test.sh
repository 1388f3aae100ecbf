#!/usr/bin/env bash
# The project's test command: installs the glTF-Validator the tests use
# (into tools/node_modules), then runs the whole test suite in release mode
# and closes with one summary line over every test binary.
# Extra arguments are passed to cargo test (e.g. a test name filter).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/install-validator.sh
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
cargo test --release "$@" 2>&1 | tee "$log" || status=$?
passed=$(grep -E '^test result:' "$log" | sed -E 's/.* ([0-9]+) passed.*/\1/' | awk '{s+=$1} END {print s+0}')
failed=$(grep -E '^test result:' "$log" | sed -E 's/.* ([0-9]+) failed.*/\1/' | awk '{s+=$1} END {print s+0}')
echo
echo "all tests: $passed passed, $failed failed"
if [ "$status" -ne 0 ]; then
    exit "$status"
fi
if [ "$passed" -eq 0 ]; then
    echo "ERROR: no test ran" >&2
    exit 1
fi
