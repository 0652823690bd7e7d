#!/usr/bin/env bash
# End-to-end time and peak memory of `boresight calibrate` (method A) on simulated Level-1 spans:
# 3 heads at 2 Hz, ACC1A at 10 Hz, QSA1B; the calibration scenario with its manoeuvres in the first
# 15 minutes (config/sim_gracefo_calibration_short.yaml), 1 h, 6 h, 1 day and 3 days by default.
#
#   tools/bench_calibrate.sh [--runs N] [--spans "3600 21600 86400 259200"] [--scenario FILE]
#                            [--config FILE] [--orbit] [-- EXTRA CALIBRATE OPTIONS]
#
# --scenario (default config/sim_gracefo_calibration_short.yaml) and --config (default
# config/gracefo_ideal.yaml) choose the world and the platform file; --orbit adds the GNV1B file (the
# attitude-domain estimate's aberration and orbit harmonics, the CRN's thermal fit). The attitude
# domain on the realistic preset:
#   tools/bench_calibrate.sh --runs 3 --spans "21600 86400" --scenario config/sim_gracefo_calibration_realistic.yaml \
#     --config config/gracefo.yaml --orbit -- --method attitude
# BORESIGHT_CLI=PATH runs another build's boresight on the same files (an earlier commit, to compare).
# Each span is simulated once (seed 7, no LCM log) into $BORESIGHT_BENCH_DIR (default
# ${TMPDIR:-/tmp}/boresight-bench; 3 days take about a minute and 1 GB) and reused; then calibrate runs
# N times (default 5) under GNU time (/usr/bin/time): wall time, CPU time (user + system, all threads) and
# peak RSS per run, then the ranges, and calibrate's own stage line (replay and span / solve / output,
# wall time and peak RSS after each) of the last run.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
runs=5
spans="3600 21600 86400 259200"
scenario="$root/config/sim_gracefo_calibration_short.yaml"
config="$root/config/gracefo_ideal.yaml"
orbit=0
extra=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --runs) runs="$2"; shift 2 ;;
    --spans) spans="$2"; shift 2 ;;
    --scenario) scenario="$2"; shift 2 ;;
    --config) config="$2"; shift 2 ;;
    --orbit) orbit=1; shift ;;
    --) shift; extra=("$@"); break ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "bench_calibrate.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
cli="${BORESIGHT_CLI:-$root/build/tools/boresight}"  # another build's binary, to compare
[[ -x "$cli" ]] || { echo "bench_calibrate.sh: build first (tools/build.sh)" >&2; exit 1; }
"$cli" calibrate --help >/dev/null 2>&1 || { echo "bench_calibrate.sh: this build has no calibrate command" >&2; exit 1; }
[[ -x /usr/bin/time ]] || { echo "bench_calibrate.sh: needs GNU time (/usr/bin/time)" >&2; exit 1; }
dir="${BORESIGHT_BENCH_DIR:-${TMPDIR:-/tmp}/boresight-bench}"
mkdir -p "$dir"
[[ -f "$scenario" ]] || scenario="$root/$scenario"
[[ -f "$config" ]] || config="$root/$config"
tag="$(basename "$scenario" .yaml)"
[[ "$tag" == sim_gracefo_calibration_short ]] && tag=""  # the directories of earlier runs
for s in $spans; do
  out="$dir/calibrate_${tag:+${tag}_}$s"
  if [[ ! -f "$out/truth.yaml" ]]; then
    "$cli" simulate --scenario "$scenario" --seed 7 --duration "$s" --out "$out" --quiet --no-lcm
  fi
done
for s in $spans; do
  d="$dir/calibrate_${tag:+${tag}_}$s"
  inputs=("$d"/SCA1A_*.txt "$d"/ACC1A_*.txt "$d"/QSA1B_*.txt)
  [[ $orbit == 1 ]] && inputs+=("$d"/GNV1B_*.txt)
  times=()
  for ((i = 1; i <= runs; i++)); do
    # by default the ideal noise preset: the spans carry the simulator's white 6"/48" head noise
    /usr/bin/time -f "%e %M %U %S" -o "$dir/time.txt" "$cli" calibrate --config "$config" \
      "${inputs[@]}" --json "$dir/calibrate.json" ${extra[@]+"${extra[@]}"} \
      >"$dir/calibrate.log" 2>&1 || { echo "calibrate ${s} s failed:"; tail -5 "$dir/calibrate.log"; exit 1; }
    read -r secs kb usr sys <"$dir/time.txt"
    cpu=$(awk -v u="$usr" -v s="$sys" 'BEGIN { print u + s }')
    awk -v s="$s" -v i="$i" -v t="$secs" -v kb="$kb" -v c="$cpu" \
      'BEGIN { printf "calibrate %6d s (%5.1f h) run %d: %.2f s wall, %.2f s CPU, peak RSS %.1f MB\n", s, s / 3600, i, t, c, kb / 1024 }'
    times+=("$secs $kb $cpu")
  done
  printf '%s\n' "${times[@]}" | awk -v s="$s" -v h="$(grep -o '"epochs": [0-9]*' "$dir/calibrate.json" | head -1)" '
    NR == 1 { tmin = tmax = $1; mmin = mmax = $2; cmin = cmax = $3 }
    { if ($1 < tmin) tmin = $1; if ($1 > tmax) tmax = $1; if ($2 < mmin) mmin = $2; if ($2 > mmax) mmax = $2
      if ($3 < cmin) cmin = $3; if ($3 > cmax) cmax = $3 }
    END { printf "calibrate %6d s: %.2f-%.2f s wall, %.2f-%.2f s CPU, peak RSS %.1f-%.1f MB (%s)\n", s, tmin, tmax,
                 cmin, cmax, mmin / 1024, mmax / 1024, h }'
  grep '^stages:' "$dir/calibrate.log" | sed "s/^/calibrate ${s} s /"
done
