#!/usr/bin/env bash
# The project's test command: installs the glTF-Validator the tests use
# (into tools/node_modules), then runs the whole test suite in release mode.
# Extra arguments are passed to cargo test (e.g. a test name filter).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

bash scripts/install-validator.sh
cargo test --release "$@"
