#!/usr/bin/env bash
# Method A over many days (`boresight calibrate --method attitude --window 86400`): DAYS simulated days of
# the calibration scenario (realistic preset unless SCENARIO is given) with one set of calibration manoeuvres every day (1-deg sinusoids
# about x, y and z at 1, 2 and 3 h, 1000 s each), calibrated day by day and combined. Prints the wall time
# and the peak resident memory of calibrate (GNU time), the per-day seconds, and the joint's table (the
# spread between days, tau, is the data's own measure of what moves the alignment from day to day:
# the preset's thermal wander, its field-of-view error's daily mean). Label bench (not in CI).
# Usage: windows_days.sh BUILD_DIR OUT_DIR DAYS [SEED [SCENARIO CONFIG]]
#   e.g. windows_days.sh build /tmp/days 30 1
#        windows_days.sh build /tmp/days_ideal 30 1 config/sim_gracefo_calibration.yaml config/gracefo_ideal.yaml
set -euo pipefail
build=${1:?build dir}; out=${2:?output dir}; days=${3:?days}; seed=${4:-1}
src=$(cd "$(dirname "$0")/../../.." && pwd)
base=$(realpath "${5:-$src/config/sim_gracefo_calibration_realistic.yaml}")
config=$(realpath "${6:-$src/config/gracefo.yaml}")
bin="$build/tools/boresight"
mkdir -p "$out"
scen="$out/days.yaml"
{
  echo "# written by test/calib/bench/windows_days.sh: the realistic calibration day, manoeuvres every day"
  echo "base: $base"
  echo "attitude:"
  echo "  manoeuvres:"
  for ((d = 0; d < days; ++d)); do
    t=$((d * 86400))
    echo "    - {amplitude_deg: [1.0, 0, 0], period_s: 100, start_s: $((t + 3600)), duration_s: 1000}"
    echo "    - {amplitude_deg: [0, 1.0, 0], period_s: 100, start_s: $((t + 7200)), duration_s: 1000}"
    echo "    - {amplitude_deg: [0, 0, 1.0], period_s: 100, start_s: $((t + 10800)), duration_s: 1000}"
  done
} > "$scen"
data="$out/data"
if [[ ! -f "$data/truth.yaml" ]]; then
  rm -rf "$data"
  /usr/bin/time -f "simulate: %e s, peak %M kB" "$bin" simulate --scenario "$scen" --seed "$seed" --duration $((days * 86400)) \
    --out "$data" --no-lcm --quiet
fi
/usr/bin/time -f "calibrate: %e s wall, %U s user, peak %M kB" "$bin" calibrate --config "$config" \
  "$data"/SCA1A_*.txt "$data"/ACC1A_*.txt "$data"/QSA1B_*.txt "$data"/GNV1B_*.txt --method attitude --window 86400 \
  --json "$out/windows.json" --report "$out/report" > "$out/calibrate.txt" 2> "$out/time.txt" || { cat "$out/calibrate.txt" "$out/time.txt"; exit 1; }
cat "$out/time.txt"
grep -E "^window " "$out/calibrate.txt" | sed -e 's/: .*accelerometer samples: / /' | awk '{print "  " $0}' | head -n 40
sed -n '/^joint of/,/^stages/p' "$out/calibrate.txt"
# Whether the beta modulation of the orbit harmonics was determined (the terms are in the table above).
python3 - "$out/windows.json" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1]))["joint"]["beta_modulation"]
print("beta modulation:", j["status"])
EOF
