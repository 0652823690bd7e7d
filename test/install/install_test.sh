#!/usr/bin/env bash
# Installs the build into a temporary prefix and builds + runs a downstream project against it.
#   install_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1"; build="$2"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
test -x "$tmp/prefix/bin/boresight" || { echo "bin/boresight not installed"; exit 1; }
test -f "$tmp/prefix/include/boresight/core/conventions.h" || { echo "headers not installed"; exit 1; }
"$tmp/prefix/bin/boresight" --help >/dev/null
cmake -S "$src/test/install/consumer" -B "$tmp/consumer" -G Ninja -DCMAKE_PREFIX_PATH="$tmp/prefix" >"$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/consumer" >/dev/null
"$tmp/consumer/consumer"
