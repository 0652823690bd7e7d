#!/usr/bin/env bash
# Benchmark of the node (not in CI; ctest label bench): a simulated day (about 1.4 million messages)
# replayed through boresightd with the calibration worker running, RUNS times, and resident memory of
# a DAYS-day replay against a one-day replay (flat: bounded by the worker's span window).
# Usage: test/bench/bench_node.sh BUILD_DIR [RUNS=3] [DAYS=7]
# Prints wall time, messages/s and step latency per run (from boresightd's summary JSON) and the peak
# resident memory (GNU time). Timing taken while other jobs run is loaded: say so with the figures.
set -euo pipefail
build=${1:?usage: bench_node.sh BUILD_DIR [RUNS] [DAYS]}
runs=${2:-3}
days=${3:-7}
here=$(cd "$(dirname "$0")/../.." && pwd)
cli=$build/tools/boresight
node=$build/tools/boresightd
work=$(mktemp -d "${TMPDIR:-/tmp}/boresight-bench-node.XXXXXX")
trap 'rm -rf "$work"' EXIT
# the ideal noise preset (the log is simulated from config/sim_gracefo_calibration.yaml: white 6"/48")
sed "s#^platform: gracefo_ideal.yaml#platform: $here/config/gracefo_ideal.yaml#" "$here/config/boresightd.yaml" > "$work/node.yaml"
grep -q "^platform: $here/config/gracefo_ideal.yaml" "$work/node.yaml"

"$cli" simulate --scenario "$here/config/sim_gracefo_calibration.yaml" --seed 5 --duration 86400 --out "$work/day" --quiet
echo "one simulated day: $(du -h "$work/day/sim.lcmlog" | cut -f1) log"
for i in $(seq 1 "$runs"); do
  /usr/bin/time -f "%M" -o "$work/rss" "$node" --config "$work/node.yaml" --replay "$work/day/sim.lcmlog" \
    --summary-json "$work/s.json" > /dev/null
  cat "$work/rss" >> "$work/rss_day"  # every day replay's peak, for the soak's comparison
  python3 - "$work/s.json" "$(cat "$work/rss")" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); l = s["step_latency_us"]; h = s["head_step_latency_us"]
print(f"day replay: {s['received']} messages in {s['wall_s']:.2f} s = {s['messages_per_s']:.0f} messages/s, "
      f"{s['calibrations_published']} calibrations, ring high water {s['ring_high_water']}, waits {s['ring_waits']}; "
      f"step latency p50 {l['p50']:.2f} us, p99 {l['p99']:.2f} us, p99.9 {l['p99.9']:.2f} us, max {l['max']:.0f} us "
      f"(head epochs p50 {h['p50']:.2f}, p99 {h['p99']:.2f}, p99.9 {h['p99.9']:.2f} us); "
      f"peak RSS {int(sys.argv[2]) / 1024:.1f} MB")
w = s["worker"]
print(f"  worker: {w['solves']} solves, CPU per solve {w['cpu_s_mean']:.3f} s mean, {w['cpu_s_max']:.3f} s max "
      f"(wall max {w['wall_s_max']:.3f} s), largest span {w['observations_max']} epochs ({w['observation_mb_max']:.1f} MB)")
PY
done
if [[ $days -gt 1 ]]; then
  "$cli" simulate --scenario "$here/config/sim_gracefo_calibration.yaml" --seed 6 --duration $((days * 86400)) \
    --out "$work/long" --quiet
  rm -f "$work"/long/*.txt  # the Level-1 files are not needed
  # The soak: the DAYS-day log replayed twice with the worker in lockstep, its outputs recorded. Resident
  # memory is sampled every second of the first run and printed per day of data
  # (the replay's rate is steady, so the elapsed fraction of the wall time stands for the fraction of
  # the days); the two records must be byte-identical and every message accounted for.
  for run in 1 2; do
    # GNU time gives the true peak of the whole replay (the 1 s samples below can miss a short one).
    /usr/bin/time -f "%M" -o "$work/rss_long_$run" "$node" --config "$work/node.yaml" --replay "$work/long/sim.lcmlog" --record "$work/rec_$run.lcm" \
      --summary-json "$work/l_$run.json" > /dev/null 2> "$work/stderr_$run" &
    pid=$!
    : > "$work/rss_samples_$run"
    while kill -0 "$pid" 2> /dev/null; do
      # the node is GNU time's child
      cpid=$(pgrep -P "$pid" | head -1 || true)
      [[ -n "$cpid" ]] && { awk '/VmRSS/ {print $2}' "/proc/$cpid/status" 2> /dev/null >> "$work/rss_samples_$run" || true; }
      sleep 1
    done
    wait "$pid"
    echo "run $run: $(grep -c 'refused' "$work/stderr_$run" || true) calibrations refused (boresightd's log)"
  done
  python3 - "$work" "$days" <<'PY'
import json, sys
w, days = sys.argv[1], int(sys.argv[2])
a, b = json.load(open(f"{w}/l_1.json")), json.load(open(f"{w}/l_2.json"))
rss = [int(x) for x in open(f"{w}/rss_samples_1").read().split() if x.strip()]
w = a["worker"]
print(f"worker over {days} days: {w['solves']} solves, CPU per solve {w['cpu_s_mean']:.3f} s mean, {w['cpu_s_max']:.3f} s max, "
      f"largest span {w['observations_max']} epochs ({w['observation_mb_max']:.1f} MB)")
print(f"{days}-day replay: {a['received']} messages in {a['wall_s']:.1f} s ({a['messages_per_s']:.0f} messages/s), "
      f"{a['calibrations_published']} calibrations, accounted {a['accounted']}, "
      f"received == used + rejected: {a['received'] == a['used'] + sum(a['rejected'].values())}")
peak_long = max(int(open(f"{sys.argv[1]}/rss_long_{r}").read().split()[-1]) for r in (1, 2)) / 1024
day = [int(x) / 1024 for x in open(f"{sys.argv[1]}/rss_day").read().split() if x.strip()]
print(f"peak resident memory (GNU time) of the {days}-day replays {peak_long:.1f} MB (the larger of the two) against "
      f"the day replays' {min(day):.1f}-{max(day):.1f} MB: {100 * (peak_long / max(day) - 1):+.1f} % over the larger")
if rss:
    per = []
    for d in range(1, days + 1):
        seg = rss[(d - 1) * len(rss) // days: max(d * len(rss) // days, (d - 1) * len(rss) // days + 1)]
        per.append(max(seg) / 1024)
    print("peak resident memory per day of data (MB, 1 s samples): " + ", ".join(f"{v:.1f}" for v in per)
          + f"; first day {per[0]:.1f}, last {per[-1]:.1f} ({100 * (per[-1] / per[0] - 1):+.1f} %)")
same = {k: a[k] for k in ("received", "used", "rows", "published", "calibrations_published")} == \
       {k: b[k] for k in ("received", "used", "rows", "published", "calibrations_published")}
print(f"second run: the same counts: {same}")
PY
  if cmp -s "$work/rec_1.lcm" "$work/rec_2.lcm"; then
    echo "the two runs' recorded outputs are byte-identical ($(du -h "$work/rec_1.lcm" | cut -f1))"
  else
    echo "FAIL: the two runs' recorded outputs differ"; exit 1
  fi
fi
