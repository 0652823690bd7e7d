#!/usr/bin/env bash
# Benchmark of `boresight noise` on simulated days through files (not in CI; run it by hand on a quiet
# machine): `boresight simulate` writes DURATION_S of SCENARIO (three heads at 2 Hz, the accelerometer
# at 10 Hz) as Level-1 files, then `boresight noise` runs RUNS times on them under GNU time (wall clock,
# peak resident memory). The issue's target: a day in under 3 s, peak memory under 100 MB and flat in
# the span (compare DURATION_S 86400 with 259200).
# Usage: test/noise/bench/bench_noise_day.sh BUILD_DIR [RUNS=3] [DURATION_S=86400] [SCENARIO] [CONFIG]
#   SCENARIO defaults to config/sim_gracefo.yaml (the ideal preset) with CONFIG config/gracefo_ideal.yaml.
set -euo pipefail
. "$(dirname "$0")/args.sh"
bench_args bench_noise_day 3 86400 "$@"
runs=$count

/usr/bin/time -f "%e %M" -o "$work/sim_time" "$cli" simulate --scenario "$scenario" --seed 1 \
  --duration "$duration" --out "$work/day" --no-lcm --quiet
read -r sim_wall sim_rss < "$work/sim_time"
echo "simulate ${duration} s of $(basename "$scenario"): ${sim_wall} s, peak RSS $((sim_rss / 1024)) MB;" \
  "files: $(du -ch "$work"/day/*.txt | tail -1 | cut -f1)"
walls=()
rsss=()
for i in $(seq 1 "$runs"); do
  /usr/bin/time -v -o "$work/time_$i" "$cli" noise --config "$config" \
    "$work"/day/SCA1A_*.txt "$work"/day/ACC1A_*.txt "$work"/day/QSA1B_*.txt --out "$work/noise_$i" --quiet > "$work/out_$i"
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0; for (k = 1; k <= n; k++) s = s * 60 + p[k]; print s}' "$work/time_$i")
  rss=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$work/time_$i")
  walls+=("$wall")
  rsss+=("$rss")
  echo "noise run $i: wall ${wall} s, peak RSS $((rss / 1024)) MB"
done
printf '%s\n' "${walls[@]}" | sort -g | awk '{a[NR] = $1} END {printf "noise of %s s from files, %d runs: wall %s .. %s s\n", "'"$duration"'", NR, a[1], a[NR]}'
printf '%s\n' "${rsss[@]}" | sort -g | awk '{a[NR] = $1} END {printf "peak RSS %d .. %d MB\n", int(a[1] / 1024), int(a[NR] / 1024)}'
echo "table of the last run:"
cat "$work/out_$runs"
