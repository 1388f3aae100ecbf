#!/usr/bin/env bash
# The project's test command: installs the glTF-Validator the tests use
# (into tools/node_modules) and Ninja (into tools/ninja), then runs the whole test suite in release mode
# and closes with one summary line over every test binary; a whole run then
# builds the documentation, failing on any warning, and the library without
# the cli feature (no clap, indicatif, anyhow or plotters).
# Extra arguments are passed to cargo test (e.g. a test name filter).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/install-validator.sh
bash scripts/install-ninja.sh
command -v make >/dev/null 2>&1 || { echo "ERROR: make is not on PATH (the batch tests run an emitted Makefile; apt-get install make)" >&2; exit 1; }
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
# The library's documentation builds without a warning (broken or private
# links), on the whole run only (not when a filter picks tests).
if [ "$#" -eq 0 ]; then
    RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --quiet || {
        echo "ERROR: cargo doc has warnings (see above)" >&2
        exit 1
    }
    echo "cargo doc: no warnings"
    # The library builds without the command line's crates.
    cargo build --lib --release --no-default-features --quiet || {
        echo "ERROR: the library does not build without the cli feature" >&2
        exit 1
    }
    if cargo tree --no-default-features -e normal --prefix none | grep -qE "^(clap|indicatif|anyhow|plotters) "; then
        echo "ERROR: the library without the cli feature still depends on clap, indicatif, anyhow or plotters" >&2
        exit 1
    fi
    echo "library without the cli feature: builds, no command-line crates"
    # The library example runs, file to file and in memory.
    out=$(mktemp -d)
    cargo run --release --quiet --example library -- fixtures/icosphere.obj "$out" || {
        echo "ERROR: examples/library.rs failed" >&2
        exit 1
    }
    rm -rf "$out"
fi
