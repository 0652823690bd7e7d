#!/usr/bin/env python3
"""The node's message types outside C++: a simulated log replayed by boresightd (with a calibration),
its recorded outputs decoded by tools/lcm_decode.py with the lcm-gen Python types, and - where the
build made boresight_lcmtypes.jar - by LCM's Java log reader with the generated Java classes. Every
count must equal the node's own summary.

usage: lcm_bindings_test.py --src ROOT --boresight CLI --boresightd EXE --types DIR [--jar JAR --lcm-jar JAR]
"""
import argparse
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile

ap = argparse.ArgumentParser()
ap.add_argument("--src", required=True)
ap.add_argument("--boresight", required=True)
ap.add_argument("--boresightd", required=True)
ap.add_argument("--types", required=True)
ap.add_argument("--jar", default="")
ap.add_argument("--lcm-jar", default="")
a = ap.parse_args()

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        print(r.stdout)
        sys.exit("command failed (%d): %s" % (r.returncode, " ".join(cmd)))
    return r.stdout


d = tempfile.mkdtemp(prefix="lcm_bindings_")
try:
    run([a.boresight, "simulate", "--scenario", os.path.join(a.src, "config/sim_gracefo_node_demo.yaml"), "--seed", "3",
         "--duration", "1200", "--out", d, "--quiet"])
    edits = {"platform:": "platform: " + os.path.join(a.src, "config/gracefo_ideal.yaml"),
             "  cadence_s:": "  cadence_s: 3600", "  min_span_s:": "  min_span_s: 840",
             "  apply_lag_epochs:": "  apply_lag_epochs: 20"}
    lines = []
    for line in open(os.path.join(a.src, "config/boresightd.yaml")):
        for k, v in edits.items():
            if line.startswith(k):
                line = v + "\n"
        lines.append(line)
    cfg = os.path.join(d, "node.yaml")
    open(cfg, "w").writelines(lines)
    out, summ = os.path.join(d, "out.lcm"), os.path.join(d, "summary.json")
    run([a.boresightd, "--config", cfg, "--replay", os.path.join(d, "sim.lcmlog"), "--record", out, "--summary-json", summ])
    s = json.load(open(summ))
    check(s["calibrations_published"] >= 1, "the replay published a calibration (%d)" % s["calibrations_published"])

    decode = os.path.join(a.src, "tools/lcm_decode.py")
    j = os.path.join(d, "out.json")
    run([sys.executable, decode, "--types", a.types, out, "--json", j])
    dec = json.load(open(j))
    counts = dec["counts"]
    check(counts.get("BORESIGHT_ATTITUDE", 0) == s["rows"], "attitude messages %d == rows %d" % (counts.get("BORESIGHT_ATTITUDE", 0), s["rows"]))
    check(counts.get("BORESIGHT_MONITOR", 0) == s["rows"], "monitor messages == rows")
    check(counts.get("BORESIGHT_CALIBRATION", 0) == s["calibrations_published"], "calibration messages == calibrations_published")
    check(sum(counts.values()) == s["published"], "every published message decodes (%d of %d)" % (sum(counts.values()), s["published"]))
    check(not dec["unknown"], "no event of an unknown type")
    norms = [abs(math.sqrt(sum(q * q for q in m["q_I_B"])) - 1) for m in dec["messages"]["BORESIGHT_ATTITUDE"]]
    check(max(norms) < 1e-9, "every decoded attitude quaternion is unit (max error %.1e)" % max(norms))
    last = dec["messages"]["BORESIGHT_HEALTH"][-1]
    check(last["received"] == s["received"] and last["received"] == last["used"] + sum(last["rejected"]),
          "the last health message accounts for every message (%d received)" % last["received"])
    cal = dec["messages"]["BORESIGHT_CALIBRATION"][-1]
    check(cal["status"] == 0 and all(math.isfinite(v) for v in cal["common_rotation_B_arcsec"]),
          "the calibration decodes with its status and common rotation")
    # A log written with an earlier layout of a type (here: every monitor message opening with the
    # fingerprint of boresight_monitor_t version 1 from src/lcmtypes/versions.txt) is named, not decoded
    # as today's fields, and the exit status says so.
    v1 = None
    for line in open(os.path.join(a.src, "src/lcmtypes/versions.txt")):
        p = line.split()
        if len(p) >= 3 and p[0] == "boresight_monitor_t" and p[1] == "1":
            v1 = bytes.fromhex(p[2])
    check(v1 is not None, "versions.txt lists boresight_monitor_t version 1")
    blob, off, old = bytearray(open(out, "rb").read()), 0, os.path.join(d, "old.lcm")
    hdr = struct.Struct(">IqqII")
    while off < len(blob):
        _sync, _n, _ts, clen, dlen = hdr.unpack_from(blob, off)
        start = off + hdr.size
        if blob[start:start + clen] == b"BORESIGHT_MONITOR":
            blob[start + clen:start + clen + 8] = v1
        off = start + clen + dlen
    open(old, "wb").write(blob)
    jold = os.path.join(d, "old.json")
    r = subprocess.run([sys.executable, decode, "--types", a.types, old, "--json", jold],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    check(r.returncode == 3, "a log with another layout: exit status 3 (%d)" % r.returncode)
    dold = json.load(open(jold))
    check(dold["other_versions"] == [{"channel": "BORESIGHT_MONITOR", "type": "boresight_monitor_t", "version": 1,
                                      "count": s["rows"]}], "the monitor messages named as version 1: %s" % dold["other_versions"])
    check("BORESIGHT_MONITOR" not in dold["counts"] and dold["counts"].get("BORESIGHT_ATTITUDE") == s["rows"]
          and not dold["unknown"], "nothing decoded as today's monitor, the rest as before")
    check("version 1 of the type" in r.stdout, "the counts table says which version")

    # The input log decodes too: one message per received one.
    jin = os.path.join(d, "in.json")
    run([sys.executable, decode, "--types", a.types, os.path.join(d, "sim.lcmlog"), "--json", jin])
    check(sum(json.load(open(jin))["counts"].values()) == s["received"], "the input log decodes message by message")

    if a.jar and a.lcm_jar and shutil.which("javac") and shutil.which("java"):
        cls = os.path.join(d, "java")
        os.makedirs(cls)
        cp = a.lcm_jar + os.pathsep + a.jar
        run(["javac", "-nowarn", "-cp", cp, "-d", cls, os.path.join(a.src, "test/node/bindings/DecodeLog.java")])
        o = run(["java", "-cp", cp + os.pathsep + cls, "DecodeLog", out]).split()
        check(int(o[1]) == s["rows"] and int(o[3]) == s["calibrations_published"] and float(o[5]) < 1e-9,
              "Java (lcm.jar's log reader, boresight_lcmtypes.jar): %s" % " ".join(o))
    else:
        print("skip Java: no boresight_lcmtypes.jar (needs a JDK and liblcm-java's lcm.jar)")
finally:
    shutil.rmtree(d, ignore_errors=True)

if failures:
    sys.exit("%d check(s) failed" % len(failures))
print("all checks passed")
