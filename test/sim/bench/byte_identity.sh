#!/bin/sh
# Byte identity of the simulator's output between two builds of `boresight`: the committed scenarios
# that existed before the coloured-noise effects (and one run with every older effect kind that
# draws random numbers) are simulated by both programs with the same seed, and every output file is
# compared with cmp. Used when a change must not move existing output (e.g. the accelerometer noise
# moving onto the noise library, the new effects and random streams).
#
#   test/sim/bench/byte_identity.sh OLD/boresight NEW/boresight [duration_s, default 10800]
#
# Build OLD from the commit before the change (e.g. `git worktree` or `git archive` into a scratch
# directory, configure, `ninja boresight`). Exit status 0 when every file is identical.
set -eu
old=$1
new=$2
duration=${3:-10800}
here=$(cd "$(dirname "$0")/../../.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0
run() {  # name, args...
  name=$1
  shift
  # the same output directory for both (truth.yaml lists the files written, with their paths)
  "$old" simulate --seed 7 --duration "$duration" --out "$work/$name" --quiet "$@" >/dev/null
  mv "$work/$name" "$work/old_$name"
  "$new" simulate --seed 7 --duration "$duration" --out "$work/$name" --quiet "$@" >/dev/null
  for f in "$work/old_$name"/*; do
    b=$(basename "$f")
    if cmp -s "$f" "$work/$name/$b"; then
      echo "identical  $name/$b"
    else
      echo "DIFFERENT  $name/$b"
      status=1
    fi
  done
}
for s in sim_gracefo sim_audit sim_gracefo_node_demo sim_gracefo_calibration; do
  run "$s" --scenario "$here/config/$s.yaml"
done
run effects --scenario "$here/config/sim_gracefo.yaml" \
  --effect gaps:sensor=acc,per_day=300,mean_s=5 --effect gaps:sensor=2,per_day=200,mean_s=20 \
  --effect outliers:sensor=1,rate=0.001 --effect sign_flips:sensor=3,rate=0.001 \
  --effect clock_drift:sensor=acc,rate_ppm=3 --effect time_offset:sensor=all,offset_ms=20 \
  --effect thermal_periodic:sensor=2,harmonic=1,x_arcsec=5 --effect aberration \
  --effect cross_noise:sensor=all,cross_arcsec=2 --effect anisotropic_noise:sensor=1,about_arcsec=20
exit $status
