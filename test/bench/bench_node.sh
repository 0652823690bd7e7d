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
  python3 - "$work/s.json" "$(cat "$work/rss")" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); l = s["step_latency_us"]; h = s["head_step_latency_us"]
print(f"day replay: {s['received']} messages in {s['wall_s']:.2f} s = {s['messages_per_s']:.0f} messages/s, "
      f"{s['calibrations_published']} calibrations, ring high water {s['ring_high_water']}, waits {s['ring_waits']}; "
      f"step latency p50 {l['p50']:.2f} us, p99 {l['p99']:.2f} us, p99.9 {l['p99.9']:.2f} us, max {l['max']:.0f} us "
      f"(head epochs p50 {h['p50']:.2f}, p99 {h['p99']:.2f}, p99.9 {h['p99.9']:.2f} us); "
      f"peak RSS {int(sys.argv[2]) / 1024:.1f} MB")
PY
done
if [[ $days -gt 1 ]]; then
  "$cli" simulate --scenario "$here/config/sim_gracefo_calibration.yaml" --seed 6 --duration $((days * 86400)) \
    --out "$work/long" --quiet
  rm -f "$work"/long/*.txt  # the Level-1 files are not needed
  /usr/bin/time -f "%M" -o "$work/rss" "$node" --config "$work/node.yaml" --replay "$work/long/sim.lcmlog" \
    --summary-json "$work/l.json" > /dev/null
  python3 - "$work/l.json" "$(cat "$work/rss")" "$days" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"{sys.argv[3]}-day replay: {s['received']} messages in {s['wall_s']:.1f} s, {s['calibrations_published']} "
      f"calibrations; peak RSS {int(sys.argv[2]) / 1024:.1f} MB")
PY
fi
