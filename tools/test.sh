#!/usr/bin/env bash
# The test command of the README: installs what is missing, builds, runs every test (ctest) but the
# benchmarks. Real-data tests read ../shared/data/real and skip with a message when it is absent.
#   tools/test.sh [ctest arguments...]     e.g. tools/test.sh -L real
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh" build
jobs="${BORESIGHT_JOBS:-$(nproc 2>/dev/null || echo 2)}"
ctest --test-dir "$root/build" --output-on-failure -j "$jobs" -LE bench "$@"
