#!/usr/bin/env python3
"""The demo's comparison with the simulator's truth (truth.yaml): boresightd's last published
calibration (its --summary-json) and the node's health summary, or the result of `boresight calibrate`
(its --json).

The truth is mapped to the accelerometer datum the solver uses (as src/calib/DESIGN.md says):
Exp([r]x) = C_S_B(true) C_B_A(true) C_B_A(nominal)^T C_S_B(nominal)^T, r in arc seconds.
Usage: demo_node_report.py SUMMARY_OR_CALIBRATION.json truth.yaml    (exit status 1 on unreadable input)
"""
import json
import math
import sys

import yaml

ARCSEC = 180 * 3600 / math.pi


def quat_matrix(q):
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]


def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def tr(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def so3_log(r):
    c = max(-1.0, min(1.0, (r[0][0] + r[1][1] + r[2][2] - 1) / 2))
    th = math.acos(c)
    v = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]]
    f = 0.5 if th < 1e-9 else th / (2 * math.sin(th))
    return [f * x for x in v]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    try:
        summary = json.load(open(sys.argv[1]))
        truth = yaml.safe_load(open(sys.argv[2]))
    except (OSError, ValueError, yaml.YAMLError) as e:
        sys.exit("demo_node_report.py: %s" % e)
    an = truth["accelerometer"]["C_B_A_nominal"]
    at = truth["accelerometer"]["C_B_A_true"]
    expected = {}
    for h in truth["heads"]:
        e = mul(mul(mul(quat_matrix(h["q_Si_B_true"]), at), tr(an)), tr(quat_matrix(h["q_Si_B_nominal"])))
        expected[h["id"]] = [x * ARCSEC for x in so3_log(e)]
    node = "received" in summary
    cal = summary.get("last_calibration") if node else summary
    if not cal or "heads" not in cal:
        sys.exit("demo_node_report.py: %s: no calibration in it" % sys.argv[1])
    if node:
        print("Last published calibration: %s, %s, span %.1f h, %d epochs (arcsec, head frame)"
              % (cal["status"], "applied" if cal["applied"] else "not applied", cal["span_s"] / 3600, cal["epochs"]))
    else:
        print("boresight calibrate: span %.1f h, %d epochs (arcsec, head frame)" % (cal["span_s"] / 3600, cal["epochs"]))
    print("%4s %4s %10s %10s %9s %8s %7s" % ("head", "axis", "estimate", "truth", "est-true", "sigma", "/sigma"))
    chi2, n = 0.0, 0
    for h in cal["heads"]:
        t = expected[h["id"]]
        for a in range(3):
            est, sg = h["error_angles_arcsec"][a], h["sigma_arcsec"][a]  # sigma null: not determined
            d = est - t[a]
            ratio = d / sg if sg else float("nan")
            if sg:
                chi2 += ratio * ratio
                n += 1
            print("%4d %4s %10.1f %10.1f %9.1f %8.1f %7.2f" % (h["id"], "xyz"[a], est, t[a], d, sg or float("nan"), ratio))
    print("chi-square of the %d components against the reported sigmas: %.1f (correlated components: a common"
          " rotation dominates)" % (n, chi2))
    if not node:
        return
    print("common rotation handed to the published attitude (B, arcsec): %s; frame changes: %d"
          % (" ".join("%.1f" % x for x in cal["common_rotation_B_arcsec"]), summary.get("frame_changes", 0)))
    rej = summary["rejected"]
    lat = summary["step_latency_us"]
    print("\nNode health: received %d = used %d + rejected %d (%s); lost %d; calibrations published %d, applied %d;"
          % (summary["received"], summary["used"], sum(rej.values()),
             ", ".join("%s %d" % (k, v) for k, v in rej.items() if v) or "none", summary["lost"],
             summary["calibrations_published"], summary["calibrations_applied"]))
    print("ring high water %d, dropped %d, reader waits %d; step latency p50 %.2f us, p99 %.2f us, p99.9 %.2f us,"
          " max %.0f us; %.2f s wall, %.0f messages/s"
          % (summary["ring_high_water"], summary["ring_dropped"], summary["ring_waits"], lat["p50"], lat["p99"],
             lat["p99.9"], lat["max"], summary["wall_s"], summary["messages_per_s"]))
    if summary["received"] != summary["used"] + sum(rej.values()):
        sys.exit("demo_node_report.py: received != used + rejected")


if __name__ == "__main__":
    main()
