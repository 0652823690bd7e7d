#!/usr/bin/env bash
# Calibration of the audit's noise-level tests on clean simulated spans (not in CI): for SEEDS seeds of
# config/sim_audit.yaml, `boresight simulate` then `boresight audit` (heads only), and the signed z of
# every cross_noise / anisotropic_noise test from audit.json. A calibrated test gives z with mean about
# 0 and standard deviation about 1 (t with 31 degrees of freedom: 1.03) per head and axis.
# Usage: test/audit/bench/noise_z_calibration.sh BUILD_DIR [SEEDS=30] [DURATION_S=7200] [FIRST_SEED=1]
set -euo pipefail
build=${1:?usage: noise_z_calibration.sh BUILD_DIR [SEEDS] [DURATION_S] [FIRST_SEED]}
seeds=${2:-30}
duration=${3:-7200}
first=${4:-1}
here=$(cd "$(dirname "$0")/../../.." && pwd)
cli=$build/tools/boresight
work=$(mktemp -d "${TMPDIR:-/tmp}/boresight-noise-z.XXXXXX")
trap 'rm -rf "$work"' EXIT
for s in $(seq "$first" $((first + seeds - 1))); do
  d=$work/s$s
  "$cli" simulate --scenario "$here/config/sim_audit.yaml" --seed "$s" --duration "$duration" --out "$d" --quiet --no-lcm
  # the ideal noise preset: the spans carry config/sim_audit.yaml's white 6"/48" head noise
  "$cli" audit --config "$here/config/gracefo_ideal.yaml" "$d"/SCA1A_*.txt "$d"/QSA1B_*.txt --out "$d/o" --quiet > /dev/null
  python3 - "$d/o/audit.json" "$s" >> "$work/z.txt" <<'PY'
import json, math, sys
j = json.load(open(sys.argv[1]))
for e in j["effects"]:
    if e["family"] == "noise":
        p = list(e["params"].values())
        print(e["name"], e["sensor"], sys.argv[2], math.copysign(e["statistic"], p[0]["value"] - p[1]["value"]))
PY
  rm -rf "$d"
done
python3 - "$work/z.txt" "$seeds" "$duration" <<'PY'
import collections, statistics, sys
z = collections.defaultdict(list)
for line in open(sys.argv[1]):
    name, sensor, seed, v = line.split()
    z[(name, sensor)].append((float(v), seed))
print(f"noise-test z on {sys.argv[2]} clean spans of {sys.argv[3]} s (config/sim_audit.yaml)")
for (name, sensor), v in sorted(z.items()):
    vals = [a for a, _ in v]
    worst = max(v, key=lambda a: abs(a[0]))
    print(f"  {name:18s} head {sensor}: mean {statistics.mean(vals):+.2f}, sd {statistics.pstdev(vals):.2f}, "
          f"largest |z| {abs(worst[0]):.2f} (seed {worst[1]})")
PY
