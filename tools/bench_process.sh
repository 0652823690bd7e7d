#!/usr/bin/env bash
# End-to-end time and peak memory of `boresight process` on simulated Level-1 spans (3 heads, ACC1A at
# 10 Hz) of 6 h, 12 h and 3 days, and of the same 6 h span from the simulator's LCM log.
#
#   tools/bench_process.sh [--runs N] [--spans "21600 43200 259200"]
#
# The spans are simulated once into $BORESIGHT_BENCH_DIR (default ${TMPDIR:-/tmp}/boresight-bench;
# the 3-day span takes a few minutes and about 1.2 GB) and reused. Needs GNU time (/usr/bin/time).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
runs=5
spans="21600 43200 259200"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --spans) spans="$2"; shift 2 ;;
    -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
    *) echo "bench_process.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
cli="$root/build/tools/boresight"
[[ -x "$cli" ]] || { echo "bench_process.sh: build first (tools/build.sh)" >&2; exit 1; }
dir="${BORESIGHT_BENCH_DIR:-${TMPDIR:-/tmp}/boresight-bench}"
mkdir -p "$dir"
for s in $spans; do
  out="$dir/process_$s"
  if [[ ! -f "$out/sim.lcmlog" ]]; then
    "$cli" simulate --scenario "$root/config/sim_gracefo.yaml" --seed 7 --duration "$s" --out "$out" --quiet
  fi
done
measure() {  # label, then the process arguments
  local label="$1"
  shift
  for ((i = 1; i <= runs; i++)); do
    # the ideal noise preset: the spans carry the simulator's white 6"/48" head noise
    /usr/bin/time -f "%e %M" -o "$dir/time.txt" "$cli" process --config "$root/config/gracefo_ideal.yaml" "$@" \
      --out "$dir/rows.csv" >/dev/null
    read -r secs kb <"$dir/time.txt"
    awk -v l="$label" -v i="$i" -v s="$secs" -v kb="$kb" 'BEGIN { printf "%s run %d: %.2f s, peak RSS %.1f MB\n", l, i, s, kb / 1024 }'
  done
}
for s in $spans; do
  d="$dir/process_$s"
  measure "process ${s} s Level-1" "$d"/SCA1A_*.txt "$d"/ACC1A_*.txt "$d"/QSA1B_*.txt
done
first=$(echo "$spans" | awk '{print $1}')
d="$dir/process_$first"
measure "process ${first} s LCM log" "$d/sim.lcmlog" "$d"/QSA1B_*.txt
