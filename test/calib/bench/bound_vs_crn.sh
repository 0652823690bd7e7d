#!/usr/bin/env bash
# Method A's two estimators in `boresight calibrate --raw` - the CRN-domain solver and the attitude-domain
# estimate - against the raw-data bound (`boresight bound`) on the same simulated spans: per head, each
# one's error against the truth (accelerometer datum) and its reported sigma, and the raw data's bound,
# as totals over the three head axes (sqrt of the sum of squares: frame-free). An efficient estimator
# has error / bound about 1. Both estimate the bias, the scale and the time offset; the GNV1B file gives
# the attitude-domain estimate the orbit velocity for the stars' aberration (and the CRN run its thermal fit).
# Usage: bound_vs_crn.sh BUILD_DIR OUT_DIR SCENARIO CONFIG DURATION_S [SEEDS...]
#   e.g. bound_vs_crn.sh build /tmp/bvc config/sim_gracefo_calibration_realistic.yaml config/gracefo.yaml 21600 1 2 3
# Prints one line per run and head, then the RMS over runs of error / bound and the medians.
set -euo pipefail
build=${1:?build dir}; out=${2:?output dir}; scen=${3:?scenario}; cfg=${4:?platform file}; dur=${5:?duration}
shift 5
seeds=("${@:-1 2 3}")
mkdir -p "$out"
for seed in ${seeds[@]}; do
  d="$out/seed_$seed"
  rm -rf "$d"
  "$build/tools/boresight" simulate --scenario "$scen" --seed "$seed" --duration "$dur" --out "$d" --no-lcm --quiet
  "$build/tools/boresight" calibrate --config "$cfg" "$d"/SCA1A_*.txt "$d"/ACC1A_*.txt "$d"/QSA1B_*.txt "$d"/GNV1B_*.txt \
    --acc-scale --time-offset --raw --json "$d/calibrate.json" > "$d/calibrate.txt" 2>&1 || { echo "seed $seed: calibrate failed"; tail -3 "$d/calibrate.txt"; continue; }
  "$build/tools/boresight" bound --scenario "$scen" --seed "$seed" --duration "$dur" --scale --time-offset --quiet \
    --json "$d/bound.json" > /dev/null
done
python3 - "$out" "${seeds[@]}" <<'EOF'
import json, math, sys
out, seeds = sys.argv[1], sys.argv[2:]

def qmat(q):
    w, x, y, z = q
    n = math.sqrt(w*w + x*x + y*y + z*z); w, x, y, z = w/n, x/n, y/n, z/n
    return [[1-2*(y*y+z*z), 2*(x*y-w*z), 2*(x*z+w*y)],
            [2*(x*y+w*z), 1-2*(x*x+z*z), 2*(y*z-w*x)],
            [2*(x*z-w*y), 2*(y*z+w*x), 1-2*(x*x+y*y)]]
def mul(a, b): return [[sum(a[i][k]*b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
def tr(a): return [[a[j][i] for j in range(3)] for i in range(3)]
def log(c):  # rotation vector of a rotation matrix (small and moderate angles)
    ang = math.acos(max(-1.0, min(1.0, (c[0][0]+c[1][1]+c[2][2]-1)/2)))
    k = 0.5 if ang < 1e-12 else ang/(2*math.sin(ang))
    return [k*(c[2][1]-c[1][2]), k*(c[0][2]-c[2][0]), k*(c[1][0]-c[0][1])]

def truth(path):  # per head the error calibrate should find (test/tools/calibrate_test.cc expectedAngles)
    import yaml  # python3-yaml (tools/setup.sh)
    t = yaml.safe_load(open(path))
    An, At = t["accelerometer"]["C_B_A_nominal"], t["accelerometer"]["C_B_A_true"]
    heads = {}
    for h in t["heads"]:
        E = mul(mul(mul(qmat(h["q_Si_B_true"]), At), tr(An)), tr(qmat(h["q_Si_B_nominal"])))
        heads[h["id"]] = [v*180/math.pi*3600 for v in log(E)]
    return heads

def total(v): return math.sqrt(sum(x*x for x in v)) if all(x is not None for x in v) else float('inf')
rows = {"crn": [], "raw": []}
print("%5s %4s %10s %10s %10s %10s %10s %9s %9s" % ("seed", "head", "CRN err", "CRN sigma", "raw err", "raw sigma", "bound", "CRN/bnd", "raw/bnd"))
for s in seeds:
    d = "%s/seed_%s" % (out, s)
    try:
        c = json.load(open(d + "/calibrate.json")); b = json.load(open(d + "/bound.json")); t = truth(d + "/truth.yaml")
    except (OSError, ValueError) as e:
        print("seed %s: %s" % (s, e)); continue
    bh = {h["id"]: h for h in b["heads"]}
    rh = {h["id"]: h for h in c.get("attitude_domain", {}).get("heads", [])}
    for h in c["heads"]:
        i = h["id"]
        bnd = total(bh[i]["sigma_arcsec"])
        ce = total([h["error_angles_arcsec"][a] - t[i][a] for a in range(3)])
        re_ = total([rh[i]["error_angles_arcsec"][a] - t[i][a] for a in range(3)]) if i in rh else float('nan')
        rows["crn"].append(ce / bnd); rows["raw"].append(re_ / bnd)
        print("%5s %4d %10.1f %10.1f %10.1f %10.2f %10.2f %9.1f %9.2f" % (s, i, ce, total(h["sigma_arcsec"]), re_,
              total(rh[i]["sigma_arcsec"]) if i in rh else float('nan'), bnd, ce / bnd, re_ / bnd))
for k in ("crn", "raw"):
    v = [x for x in rows[k] if x == x]
    if v:
        print("%s: %d head-runs, RMS error/bound %.2f (an efficient estimator: 1)" % (k, len(v), math.sqrt(sum(x*x for x in v) / len(v))))
EOF
