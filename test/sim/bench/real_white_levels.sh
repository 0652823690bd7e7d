#!/bin/sh
# The white per-sample noise of each GRACE-FO C head on the real excerpt of 2023-06-01 (16 s), as the
# model audit estimates it from the head-pair residuals (the attitude cancels): cross-boresight per
# axis and about the boresight, with standard errors; and of the accelerometer's angular
# accelerations on the ACC1A excerpts of 2023-06-01 (10 s) and 2023-06-03 (67 s), from second
# differences (x[n+1] - 2 x[n] + x[n-1] has variance 6 sigma^2 for white noise; a smooth signal
# cancels). The numbers of config/preset_realistic.yaml and config/sim_gracefo.yaml.
#
#   test/sim/bench/real_white_levels.sh [build/tools/boresight] [real data dir]
#
# The real data: ../shared/data/real next to the project, or BORESIGHT_REAL_DATA (as the tests).
set -eu
here=$(cd "$(dirname "$0")/../../.." && pwd)
cli=${1:-$here/build/tools/boresight}
real=${2:-${BORESIGHT_REAL_DATA:-$here/../shared/data/real}}
d=$real/gracefo
if [ ! -f "$d/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt" ]; then
  echo "real data not found under $real (set BORESIGHT_REAL_DATA)" >&2
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$cli" audit --config "$here/config/gracefo.yaml" "$d/2023-06-01_L1A/SCA1A_2023-06-01_C_04.txt" \
  "$d/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt" "$d/static_2018-05-22/QSA1B_2018-05-22_C_04.txt" \
  "$d/2023-06-01_L1B/GNI1B_2023-06-01_C_04.txt" --out "$work" >/dev/null
python3 - "$work/audit.json" <<'PY'
import json, sys
a = json.load(open(sys.argv[1]))
rows = {}
for e in a["effects"]:
    if e["name"] in ("cross_noise", "anisotropic_noise"):
        key = "cross_arcsec" if e["name"] == "cross_noise" else "about_arcsec"
        p = e["params"][key]
        rows.setdefault(e["sensor"], {})[key] = (p["value"], p["sigma"])
print("white noise per sample on the real GRACE-FO C excerpt (2023-06-01, 16 s), boresight audit:")
for head in sorted(rows):
    c, b = rows[head]["cross_arcsec"], rows[head]["about_arcsec"]
    print(f"  head {head}: cross {c[0]:.2f} +- {c[1]:.2f} arcsec, about the boresight {b[0]:.1f} +- {b[1]:.1f} arcsec")
PY
for f in "$d/2023-06-01_L1A/ACC1A_2023-06-01_C_04.txt" "$d/2023-06-03_L1A/ACC1A_2023-06-03_C_04.txt"; do
  [ -f "$f" ] || continue
  # columns after the YAML header: time (2), time_ref, id, qualflg, prod_flag, lin x y z, ang x y z, ...
  awk 'f { print $10, $11, $12 } /End of YAML header/ { f = 1 }' "$f" | python3 -c "
import math, sys
r = [list(map(float, l.split())) for l in sys.stdin if l.strip()]
s = []
for k in range(3):
    x = [v[k] for v in r]
    d2 = [x[i + 1] - 2 * x[i] + x[i - 1] for i in range(1, len(x) - 1)]
    s.append(math.sqrt(sum(v * v for v in d2) / len(d2) / 6))
print('accelerometer white angular acceleration per 10 Hz sample, $(basename "$f") (%d samples): '
      'A x %.2e, A y %.2e, A z %.2e rad/s^2' % (len(r), *s))
"
done
