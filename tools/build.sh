#!/usr/bin/env bash
# Configure and build boresight (Release, Ninja) into BUILD_DIR (default: build). Extra arguments go
# to CMake, e.g. tools/build.sh build-asan -DBORESIGHT_SANITIZE=address,undefined
# Environment: BORESIGHT_BUILD_TYPE (Release), BORESIGHT_BUILD_BENCH (ON; CI sets OFF), BORESIGHT_JOBS.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build}"
shift || true
cd "$root"
"$root/tools/setup.sh"
jobs="${BORESIGHT_JOBS:-$(nproc 2>/dev/null || echo 2)}"
if [[ ! -f "$build/build.ninja" ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE="${BORESIGHT_BUILD_TYPE:-Release}" \
    -DBORESIGHT_BUILD_BENCH="${BORESIGHT_BUILD_BENCH:-ON}" "$@" >/dev/null
elif [[ $# -gt 0 ]]; then
  cmake -S . -B "$build" "$@" >/dev/null
fi
cmake --build "$build" -j "$jobs"
