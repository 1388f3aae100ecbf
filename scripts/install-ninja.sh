#!/usr/bin/env bash
# Install Ninja (PyPI package `ninja`, a static binary) into the project-local
# folder tools/ninja, for the test that runs `crackle batch --emit ninja`.
# Idempotent; fails loudly when python3/pip are missing or the install fails.
set -euo pipefail

NINJA_VERSION="1.13.2"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TARGET="$ROOT/tools/ninja"
BIN="$TARGET/bin/ninja"

die() {
    echo "install-ninja: ERROR: $*" >&2
    exit 1
}

# The PyPI build reports e.g. 1.13.2.git.kitware.jobserver-pipe-1.
version_ok() { case "$("$BIN" --version 2>/dev/null)" in "$NINJA_VERSION"*) return 0 ;; *) return 1 ;; esac; }

if [ -x "$BIN" ] && version_ok; then
    echo "install-ninja: ninja $NINJA_VERSION already installed in tools/ninja"
    exit 0
fi
command -v python3 >/dev/null 2>&1 || die "python3 is not on PATH"
python3 -m pip --version >/dev/null 2>&1 || die "pip is not available (python3 -m pip)"
rm -rf "$TARGET"
python3 -m pip install --quiet --disable-pip-version-check --no-deps --target "$TARGET" "ninja==$NINJA_VERSION" \
    || die "pip install ninja==$NINJA_VERSION failed"
# The wheel puts the binary in bin/ (older wheels: under */data/bin/).
if [ ! -x "$BIN" ]; then
    REAL="$(find "$TARGET" -type f -name ninja -path '*data/bin/*' | head -n 1)"
    [ -n "$REAL" ] || die "the ninja wheel has no ninja binary"
    mkdir -p "$TARGET/bin"
    ln -sf "$REAL" "$BIN"
fi
version_ok || die "tools/ninja/bin/ninja does not run ($("$BIN" --version 2>&1 || true))"
echo "install-ninja: ninja $NINJA_VERSION installed in tools/ninja"
