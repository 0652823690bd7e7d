#!/usr/bin/env bash
# A few runs of the method A solver on the project simulator's output (the Monte Carlo's check on
# independently simulated data). Usage: calib_sim_runs.sh BUILD_DIR OUT_DIR [SEEDS...]
# Scenarios: config/sim_gracefo_calibration.yaml (3.5 h: three 1-deg manoeuvres, thermal, aberration,
# accelerometer misalignment, scale and a 15 ms offset) and the same without thermal/aberration.
set -euo pipefail
build=${1:?build dir}; out=${2:?output dir}; shift 2
seeds=("${@:-1 2 3 4 5}")
src=$(cd "$(dirname "$0")/../../.." && pwd)
for scen in "$src/config/sim_gracefo_calibration.yaml" "$src/test/calib/bench/sim_calibration_nothermal.yaml"; do
  for seed in ${seeds[@]}; do
    d="$out/$(basename "$scen" .yaml)_$seed"
    "$build/tools/boresight" simulate --scenario "$scen" --seed "$seed" --duration 12600 --out "$d" --no-lcm --quiet
    echo "== $(basename "$scen") seed $seed"
    "$build/test/calib/calib_sim" --dir "$d" --scale --offset
  done
done
