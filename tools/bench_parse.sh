#!/usr/bin/env bash
# Parse throughput of the Level-1 readers against pandas' C parser, on the same generated full-day
# SCA1A and ACC1A files, in one run. Installs pandas with pip if it is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh" build >/dev/null
export BORESIGHT_BENCH_DIR="${BORESIGHT_BENCH_DIR:-${TMPDIR:-/tmp}/boresight-bench}"
bench="$root/build/test/bench/bench_parse"
files=$("$bench" --generate-only)
"$bench" --benchmark_filter='Parse|Read' "$@"
python3 -c "import pandas" 2>/dev/null || python3 -m pip install --quiet pandas
# shellcheck disable=SC2086
python3 "$root/tools/bench_parse_pandas.py" $files
