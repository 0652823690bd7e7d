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

plot() {  # plot CSV columns to an SVG next to the report and link it
  local csv="$1" svg="$2" title="$3" ylabel="$4"; shift 4
  "$bin" plot "$csv" --relative-x --out "$out/$svg" --title "$title" --ylabel "$ylabel" "$@" >/dev/null &&
    printf '\n![%s](%s)\n' "$title" "$svg" >>"$report"
}

if [[ -d "$real/gracefo" ]]; then
  l1a="$real/gracefo/2023-06-01_L1A"; l1b="$real/gracefo/2023-06-01_L1B"
  section "Real-time core over the real GRACE-FO sample, compared with the official SCA1B"
  echo "The three heads fused with their QSA1B mountings; the fused attitude against SCA1B (GRACE C):" >>"$report"
  run process --config "$root/config/gracefo.yaml" "$l1a/SCA1A_2023-06-01_C_04.txt" "$l1a/ACC1A_2023-06-01_C_04.txt" \
    "$real/gracefo/static_2018-05-22/QSA1B_2018-05-22_C_04.txt" --out "$out/process_gracefo.csv" \
    --compare-sca1b "$l1b/SCA1B_2023-06-01_C_04.txt" --clk1b "$l1b/CLK1B_2023-06-01_C_04.txt" || true
  plot "$out/process_gracefo.csv" iba_real.svg "GRACE C 2023-06-01: inter-boresight angle minus QSA1B value" arcsec \
    --y iba_12_dev_arcsec,iba_13_dev_arcsec,iba_23_dev_arcsec || true
fi

if has simulate; then
  section "Simulated GRACE-FO telemetry with known truth: an orbit-periodic thermal deformation"
  cat >>"$report" <<'TXT'
Two orbits with a once-per-revolution thermal deformation of head 2 injected on top of constant
mounting errors of every head (the truth is in sim/truth.yaml). The inter-boresight deviations show
the constant misalignments as offsets and head 2's orbit-periodic term in the pairs 1-2 and 2-3;
gaps are where a head is blinded by the Sun or the Earth. The star-sensor angular acceleration is
shown against the accelerometer's through the same CRN filter: the accelerometer carries its bias
(as the real ACC1A does) and thruster pulses, the star-sensor value is dominated by head noise.
TXT
  run simulate --scenario "$root/config/sim_gracefo.yaml" --seed 1 --duration 11400 --out "$out/sim" --quiet \
    --effect thermal_periodic:sensor=2,harmonic=1,x_arcsec=8 || true
  sca=$(ls "$out"/sim/SCA1A_*.txt 2>/dev/null | head -1); acc=$(ls "$out"/sim/ACC1A_*.txt 2>/dev/null | head -1)
  qsa=$(ls "$out"/sim/QSA1B_*.txt 2>/dev/null | head -1)
  if [[ -n "$sca" && -n "$acc" && -n "$qsa" ]] && has process; then
    run process --config "$root/config/gracefo.yaml" "$sca" "$acc" "$qsa" --out "$out/process_sim.csv" || true
    plot "$out/process_sim.csv" iba_sim.svg "Simulated: inter-boresight angle deviations, 101 s running mean" \
      arcsec --y iba_12_dev_arcsec,iba_13_dev_arcsec,iba_23_dev_arcsec --smooth 101 || true
    plot "$out/process_sim.csv" accel_sim.svg "Simulated: angular acceleration about body y, star sensors vs accelerometer" \
      "rad/s^2" --y a_sc_y,a_acc_y || true
  fi
fi

echo
echo "Report: $report"
