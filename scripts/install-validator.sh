#!/usr/bin/env bash
# Install the Khronos glTF-Validator (npm package `gltf-validator`) into the
# project-local folder tools/node_modules. Idempotent: does nothing when the
# pinned version is already installed. Fails loudly when node/npm are missing
# or the install fails.
set -euo pipefail

VALIDATOR_VERSION="2.0.0-dev.3.10"

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TOOLS="$ROOT/tools"
PKG_JSON="$TOOLS/node_modules/gltf-validator/package.json"

die() {
    echo "install-validator: ERROR: $*" >&2
    exit 1
}

command -v node >/dev/null 2>&1 || die "node (Node.js) is not on PATH; install it (e.g. apt-get install nodejs npm)"
command -v npm >/dev/null 2>&1 || die "npm is not on PATH; install it (e.g. apt-get install npm)"

installed_version() {
    [ -f "$PKG_JSON" ] || return 0
    node -e 'process.stdout.write(String(require(process.argv[1]).version || ""))' "$PKG_JSON" 2>/dev/null || true
}

if [ "$(installed_version)" = "$VALIDATOR_VERSION" ]; then
    echo "install-validator: gltf-validator@$VALIDATOR_VERSION already installed in tools/node_modules"
    exit 0
fi

mkdir -p "$TOOLS"
if [ ! -f "$TOOLS/package.json" ]; then
    cat >"$TOOLS/package.json" <<JSON
{
  "name": "crackle-tools",
  "private": true,
  "description": "Test-only tools for crackle (glTF validation)",
  "dependencies": {
    "gltf-validator": "$VALIDATOR_VERSION"
  }
}
JSON
fi

echo "install-validator: installing gltf-validator@$VALIDATOR_VERSION into tools/node_modules"
if ! npm install --prefix "$TOOLS" --no-audit --no-fund --save-exact \
    "gltf-validator@$VALIDATOR_VERSION" </dev/null; then
    die "npm install of gltf-validator@$VALIDATOR_VERSION failed"
fi

got="$(installed_version)"
[ "$got" = "$VALIDATOR_VERSION" ] ||
    die "after install, tools/node_modules/gltf-validator has version '${got:-<none>}', expected $VALIDATOR_VERSION"

node -e 'require(process.argv[1])' "$TOOLS/node_modules/gltf-validator" ||
    die "gltf-validator was installed but node cannot load it"

echo "install-validator: OK (gltf-validator@$VALIDATOR_VERSION)"
