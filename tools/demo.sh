#!/usr/bin/env bash
# The main job of the README: installs what is missing, builds, and runs boresight on the real
# GRACE-FO / GRACE samples (../shared/data/real, or BORESIGHT_REAL_DATA) and on simulated data,
# printing the results and writing a report to OUT (default: out/demo/REPORT.md).
#   tools/demo.sh [OUT_DIR]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:-$root/out/demo}"
"$root/tools/build.sh" build >/dev/null
bin="$root/build/tools/boresight"
real="${BORESIGHT_REAL_DATA:-$root/../shared/data/real}"
mkdir -p "$out"
report="$out/REPORT.md"
has() { "$bin" --help | grep -q "^  $1 "; }

{
  echo "# boresight demo report"
  echo
  echo "Made by \`tools/demo.sh\` with boresight $("$bin" --version | cut -d' ' -f2) on $(date -u +%Y-%m-%dT%H:%M:%SZ)."
  echo
} >"$report"

section() { printf '\n== %s\n' "$1"; printf '\n## %s\n\n' "$1" >>"$report"; }
run() {  # run a command, show it, keep its output in the report
  echo "\$ boresight ${*}"
  printf '```\n$ boresight %s\n' "$*" >>"$report"
  set +e
  "$bin" "$@" 2>&1 | tee -a "$report"
  local rc=${PIPESTATUS[0]}
  set -e
  printf '```\n' >>"$report"
  return $rc
}

if [[ -d "$real/gracefo" ]]; then
  fo="$real/gracefo"
  section "Real GRACE-FO telemetry (GRACE C, 2023-06-01): what is in the files"
  echo "Every product of the Level-1A and Level-1B excerpts, and the inter-boresight angles of the three" >>"$report"
  echo "star camera heads compared with the QSA1B alignment." >>"$report"
  run inspect "$fo/2023-06-01_L1A" "$fo/2023-06-01_L1B" "$fo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt" \
    --json "$out/inspect_gracefo.json" || true
  section "Real GRACE telemetry (GRACE A, 2003-09-14)"
  run inspect "$real/grace" --json "$out/inspect_grace.json" || true
  section "Level-1 to LCM log and back"
  run convert "$fo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt" "$fo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt" \
    --out "$out/gracefo_2023-06-01_C.lcm"
  run convert "$out/gracefo_2023-06-01_C.lcm" --to-level1 "$out/level1_from_lcm"
else
  section "Real telemetry"
  echo "The real samples were not found at $real (set BORESIGHT_REAL_DATA): skipped." | tee -a "$report"
fi

if has simulate; then
  section "Simulated GRACE-FO telemetry with known truth"
  run simulate --scenario "$root/config/sim_gracefo.yaml" --seed 1 --duration 3600 --out "$out/sim" || true
  run inspect "$out/sim" || true
fi
if has process && [[ -d "$real/gracefo" ]]; then
  section "Real-time core over the real GRACE-FO sample"
  run process --config "$root/config/gracefo.yaml" "$real/gracefo/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt" \
    "$real/gracefo/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt" --out "$out/process_gracefo.csv" || true
fi

echo
echo "Report: $report"
