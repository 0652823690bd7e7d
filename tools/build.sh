#!/usr/bin/env bash
# Configure and build boresight (Release, Ninja) into BUILD_DIR (default: build). Extra arguments go
# to CMake, e.g. tools/build.sh build-asan -DBORESIGHT_SANITIZE=address,undefined
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build}"
shift || true
cd "$root"
"$root/tools/setup.sh"
jobs="${BORESIGHT_JOBS:-$(nproc 2>/dev/null || echo 2)}"
if [[ ! -f "$build/build.ninja" ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE="${BORESIGHT_BUILD_TYPE:-Release}" "$@" >/dev/null
elif [[ $# -gt 0 ]]; then
  cmake -S . -B "$build" "$@" >/dev/null
fi
cmake --build "$build" -j "$jobs"
