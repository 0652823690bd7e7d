#!/usr/bin/env bash
# Parse throughput of the Level-1 readers against pandas' C parser, on the same generated full-day
# SCA1A and ACC1A files, in one run. Installs pandas with pip if it is missing.
#
#   tools/bench_parse.sh [--runs N] [google benchmark options...]
#
# 1. bench_parse (Google Benchmark): in-memory parsers, the block-parallel summary `inspect` uses,
#    the streaming record reader of the replay engine.
# 2. `boresight inspect` on the full-day ACC1A, end to end (process start to exit), N runs with the
#    default threads and N with --threads 1: wall time, MB/s and peak RSS (/usr/bin/time).
# 3. pandas' C parser on the same files (best and range of N runs, and its peak RSS).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
runs=5
if [[ "${1:-}" == "--runs" ]]; then
  runs="$2"
  shift 2
fi
"$root/tools/build.sh" build >/dev/null
export BORESIGHT_BENCH_DIR="${BORESIGHT_BENCH_DIR:-${TMPDIR:-/tmp}/boresight-bench}"
bench="$root/build/test/bench/bench_parse"
cli="$root/build/tools/boresight"
files=$("$bench" --generate-only)
acc=$(echo "$files" | grep ACC1A)
"$bench" --benchmark_filter='Parse|Read|Summarize|Stream' "$@"
echo
size=$(stat -c %s "$acc")
for threads in 0 1; do
  for ((i = 1; i <= runs; i++)); do
    /usr/bin/time -f "%e %M" -o "$BORESIGHT_BENCH_DIR/time.txt" "$cli" inspect --threads "$threads" "$acc" >/dev/null
    read -r secs kb <"$BORESIGHT_BENCH_DIR/time.txt"
    awk -v s="$secs" -v kb="$kb" -v b="$size" -v t="$threads" -v i="$i" \
      'BEGIN { printf "boresight inspect --threads %d (0 = default): run %d: %.2f s, %.0f MB/s, peak RSS %.1f MB\n", t, i, s, b / 1e6 / s, kb / 1024 }'
  done
done
echo
python3 -c "import pandas" 2>/dev/null || python3 -m pip install --quiet pandas
# shellcheck disable=SC2086
python3 "$root/tools/bench_parse_pandas.py" --repeat "$runs" $files
