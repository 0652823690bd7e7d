#!/usr/bin/env bash
# Rates across a gap of every head during a manoeuvre, end to end through `boresight process` (not in
# CI): the short calibration scenario (5-deg, 40 s oscillations; peak angular acceleration 2e-3
# rad/s^2) simulated once, every head's SCA1A records cut from START to START + LENGTH seconds (at a
# peak of the acceleration by default), and the file processed three times: without the cut, with
# the default local fit and with `bridge_fit: linear`. Prints, for the rows whose rate window holds
# bridged samples (`rate_bridged` > 0), the largest rate and acceleration difference to the uncut run
# in units of the uncut run's median nominal sigma, and against the local fit's published sigmas.
# Usage: test/bench/gap_bridge.sh BUILD_DIR [START_S=187] [LENGTH_S=6] [SEED=3]
set -euo pipefail
build=${1:?usage: gap_bridge.sh BUILD_DIR [START_S] [LENGTH_S] [SEED]}
start=${2:-187}
length=${3:-6}
seed=${4:-3}
here=$(cd "$(dirname "$0")/../.." && pwd)
cli=$build/tools/boresight
work=$(mktemp -d "${TMPDIR:-/tmp}/boresight-gap.XXXXXX")
trap 'rm -rf "$work"' EXIT
"$cli" simulate --scenario "$here/config/sim_gracefo_calibration_short.yaml" --seed "$seed" --duration 1800 \
  --out "$work/sim" --no-lcm --quiet
sca=$(ls "$work"/sim/SCA1A_*.txt)
# the first record's whole second is the scenario's time origin
t0=$(awk '/End of YAML/{f=1; next} f{print $1; exit}' "$sca")
awk -v a="$((t0 + start))" -v b="$((t0 + start + length))" \
  'h == 0 {print; if (/End of YAML/) h = 1; next} {t = $1 + $2 / 1e6; if (t >= a && t < b) next; print}' \
  "$sca" > "$work/SCA1A_cut.txt"
echo "cut $(( $(wc -l < "$sca") - $(wc -l < "$work/SCA1A_cut.txt") )) head records from $start s to $((start + length)) s"
sed 's/^\(  bridge_fit:\) local_fit.*/\1 linear/' "$here/config/gracefo.yaml" > "$work/linear.yaml"
grep -q "bridge_fit: linear" "$work/linear.yaml"
rest=("$work"/sim/ACC1A_*.txt "$work"/sim/QSA1B_*.txt)
"$cli" process --config "$here/config/gracefo.yaml" "$sca" "${rest[@]}" --out "$work/nogap.csv" > /dev/null
"$cli" process --config "$here/config/gracefo.yaml" "$work/SCA1A_cut.txt" "${rest[@]}" --out "$work/local.csv" > /dev/null
"$cli" process --config "$work/linear.yaml" "$work/SCA1A_cut.txt" "${rest[@]}" --out "$work/linear.csv" > /dev/null
python3 - "$work" <<'PY'
import csv, math, statistics, sys
d = sys.argv[1]
def load(n):
    with open(f"{d}/{n}.csv") as f:
        return {r["time_s"]: r for r in csv.DictReader(f)}
def num(r, k):
    try:
        return float(r[k])
    except ValueError:
        return float("nan")
ref, loc, lin = load("nogap"), load("local"), load("linear")
ws = statistics.median(num(r, "w_sigma_x") for r in ref.values() if not math.isnan(num(r, "w_sigma_x")))
As = statistics.median(num(r, "a_sc_sigma_x") for r in ref.values() if not math.isnan(num(r, "a_sc_sigma_x")))
print(f"{len(ref)} rows; median nominal sigma: rate {ws:.3e} rad/s, acceleration {As:.3e} rad/s^2")
for name, run in (("local fit", loc), ("linear", lin)):
    flagged = beyond = 0
    worst_w = worst_a = worst_sw = worst_sa = 0.0
    for t, r in run.items():
        if t not in ref or math.isnan(num(r, "w_x")) or math.isnan(num(ref[t], "w_x")) or int(r["rate_bridged"]) == 0:
            continue
        flagged += 1
        dw = max(abs(num(r, "w_" + k) - num(ref[t], "w_" + k)) for k in "xyz")
        da = max(abs(num(r, "a_sc_" + k) - num(ref[t], "a_sc_" + k)) for k in "xyz")
        sw = max(num(loc[t], "w_sigma_" + k) for k in "xyz")
        sa = max(num(loc[t], "a_sc_sigma_" + k) for k in "xyz")
        worst_w, worst_a = max(worst_w, dw / ws), max(worst_a, da / As)
        worst_sw, worst_sa = max(worst_sw, dw / sw), max(worst_sa, da / sa)
        beyond += dw > 3 * sw or da > 3 * sa
    print(f"{name:9s}: {flagged} flagged rows; largest difference to the uncut run {worst_w:.1f} (rate) and "
          f"{worst_a:.1f} (acceleration) median nominal sigmas; {worst_sw:.2f} / {worst_sa:.2f} of the local "
          f"fit's published sigmas, {beyond} rows beyond 3")
PY
