#!/usr/bin/env bash
# Monte Carlo of `boresight noise`'s head white levels as the whole command computes them (not in CI;
# run by hand): for SEEDS seeds, `boresight simulate` writes DURATION_S of SCENARIO, `boresight noise`
# fits it with CONFIG, and each head axis's chosen white level is compared with the truth written in
# truth.yaml (noise_cross_arcsec / noise_about_arcsec per head). Printed per axis kind and overall: the
# mean and standard deviation of z = (fit - truth) / sigma, the mean of z^2 with its chi-square 95 %
# bounds, and how many are within 3 sigma. Calibrated sigmas give mean z^2 inside the bounds.
# Usage: test/noise/bench/white_level_mc.sh BUILD_DIR [SEEDS=20] [DURATION_S=21600] [SCENARIO] [CONFIG]
#   SCENARIO defaults to config/sim_gracefo.yaml (the ideal preset: white head noise only) with CONFIG
#   config/gracefo_ideal.yaml; the realistic preset is config/sim_gracefo_realistic.yaml with
#   config/gracefo.yaml (minutes per day: the exact fits of the coloured parts).
set -euo pipefail
. "$(dirname "$0")/args.sh"
bench_args white_level_mc 20 21600 "$@"
seeds=$count
for s in $(seq 1 "$seeds"); do
  d=$work/s$s
  "$cli" simulate --scenario "$scenario" --seed "$s" --duration "$duration" --out "$d" --quiet --no-lcm
  "$cli" noise --config "$config" "$d"/SCA1A_*.txt "$d"/ACC1A_*.txt "$d"/QSA1B_*.txt --out "$d/o" --quiet > /dev/null
  python3 - "$d/truth.yaml" "$d/o/noise.json" "$s" >> "$work/z.txt" <<'PY'
import json, re, sys
truth, head = {}, None
for line in open(sys.argv[1]):
    m = re.match(r"\s*- id: (\d+)", line)
    if m:
        head = int(m.group(1))
    m = re.match(r"\s*noise_(cross|about)_arcsec: ([-\d.eE+]+)", line)
    if m and head is not None:
        truth[(head, m.group(1))] = float(m.group(2))
for a in json.load(open(sys.argv[2]))["axes"]:
    if not a["sensor"].startswith("head "):
        continue
    h = int(a["sensor"].split()[1])
    kind = "about" if a["axis"] == "about_boresight" else "cross"
    p = next((p for p in a["chosen"]["params"] if p["name"] == "white.sigma"), None)
    if p is None or not p.get("determined", True) or not p.get("sigma"):
        why = (p or {}).get("note") or "no white level in the chosen model " + a["chosen"]["structure"]
        print("missing", h, a["axis"], sys.argv[3], why.replace(" ", "_"))
        continue
    t = truth.get((h, kind))
    if t is not None:
        print(kind, h, a["axis"], sys.argv[3], (p["value"] - t) / p["sigma"])
PY
  rm -rf "$d"
  echo "seed $s done" >&2
done
python3 - "$work/z.txt" "$seeds" "$duration" "$(basename "$scenario")" <<'PY'
import collections, math, sys
rows = [l.split() for l in open(sys.argv[1])]
groups = collections.defaultdict(list)
missing = []
for kind, head, axis, seed, z in rows:
    if kind == "missing":
        missing.append(f"seed {seed} head {head} {axis}: {z.replace('_', ' ')}")
        continue
    groups[kind].append(float(z))
    groups["all"].append(float(z))
print(f"head white levels of `boresight noise` on {sys.argv[2]} simulated spans of {sys.argv[3]} s ({sys.argv[4]})")
for k in ("cross", "about", "all"):
    z = groups.get(k, [])
    if not z:
        continue
    n = len(z)
    mean = sum(z) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in z) / max(n - 1, 1))
    m2 = sum(v * v for v in z) / n
    # chi-square 95 % quantiles over n (Wilson-Hilferty; within 1 % of the exact ones from n = 10)
    c = math.sqrt(2 / (9 * n))
    lo, hi = (1 - 2 / (9 * n) - 1.96 * c) ** 3, (1 - 2 / (9 * n) + 1.96 * c) ** 3
    inside = sum(abs(v) <= 3 for v in z)
    flag = "" if lo <= m2 <= hi else "  OUTSIDE"
    print(f"  {k:5s}: {n} levels, z mean {mean:+.3f} sd {sd:.3f}; mean z^2 {m2:.3f} (95 % bounds {lo:.3f}-{hi:.3f}){flag}; "
          f"within 3 sigma {inside}/{n}")
for m in missing:
    print("  no determined white level:", m)
PY
