#!/usr/bin/env python3
"""The node live, on loopback multicast: a simulated log played by `lcm-logplayer` (10x real time)
while `boresightd` listens on a udpm URL of its own (ttl=0: the traffic stays on this machine), then
SIGINT. Every message sent must be accounted for (received + lost == sent, received == used +
rejected), and the published rows must be those of a replay of the same log. `sent` is what the
replay of the same log received. Skips (exit code 77) with the reason where the machine has no
multicast route (boresightd cannot open the URL, or nothing arrives).

Messages lost after a channel's last received one cannot be counted by the node (nothing follows to
show the gap); at 10x real time (about 170 messages/s) none were lost in the runs made so far.

usage: node_live_test.py --src ROOT --boresight CLI --boresightd EXE [--speed 10] [--port 7683]
"""
import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

SKIP = 77

ap = argparse.ArgumentParser()
ap.add_argument("--src", required=True)
ap.add_argument("--boresight", required=True)
ap.add_argument("--boresightd", required=True)
ap.add_argument("--speed", type=float, default=10.0)
ap.add_argument("--port", type=int, default=7683)
a = ap.parse_args()

player = shutil.which("lcm-logplayer")
if not player:
    print("SKIP: lcm-logplayer is not installed (Debian package liblcm-bin)")
    sys.exit(SKIP)

failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def run(cmd, timeout=120):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout)
    if r.returncode != 0:
        print(r.stdout)
        sys.exit("command failed (%d): %s" % (r.returncode, " ".join(cmd)))
    return r.stdout


url = "udpm://239.255.76.67:%d?ttl=0" % a.port
d = tempfile.mkdtemp(prefix="node_live_")
node = None
try:
    run([a.boresight, "simulate", "--scenario", os.path.join(a.src, "config/sim_gracefo_node_demo.yaml"), "--seed", "5",
         "--duration", "120", "--out", d, "--quiet"])
    lines = []
    for line in open(os.path.join(a.src, "config/boresightd.yaml")):
        if line.startswith("platform:"):
            line = "platform: " + os.path.join(a.src, "config/gracefo_ideal.yaml") + "\n"
        elif line.startswith("lcm_url:"):
            line = 'lcm_url: "%s"\n' % url
        lines.append(line)
    cfg = os.path.join(d, "node.yaml")
    open(cfg, "w").writelines(lines)
    log = os.path.join(d, "sim.lcmlog")

    # What was sent: the replay of the same log.
    rep = os.path.join(d, "replay.json")
    run([a.boresightd, "--config", cfg, "--replay", log, "--summary-json", rep])
    r = json.load(open(rep))
    sent = r["received"]

    live = os.path.join(d, "live.json")
    out = open(os.path.join(d, "live.out"), "w")
    node = subprocess.Popen([a.boresightd, "--config", cfg, "--summary-json", live], stdout=out, stderr=subprocess.STDOUT)
    # Subscribed before the first message: boresightd says "listening on" once it has subscribed (a
    # message sent before would be missed, and one missed before the first received cannot be counted).
    deadline = time.time() + 30
    while time.time() < deadline and node.poll() is None:
        if "listening on" in open(os.path.join(d, "live.out")).read():
            break
        time.sleep(0.1)
    time.sleep(0.2)
    if node.poll() is not None:
        out.close()
        text = open(os.path.join(d, "live.out")).read()
        print(text)
        print("SKIP: boresightd could not listen on %s (no multicast route?)" % url)
        sys.exit(SKIP)
    t0 = time.time()
    run([player, "-s", str(a.speed), "-l", url, log], timeout=120)
    played_s = time.time() - t0
    time.sleep(1.0)  # the last datagrams in
    node.send_signal(signal.SIGINT)
    try:
        rc = node.wait(timeout=30)
    except subprocess.TimeoutExpired:
        node.kill()
        sys.exit("boresightd did not stop within 30 s of SIGINT")
    out.close()
    print(open(os.path.join(d, "live.out")).read().strip().splitlines()[-1])
    check(rc == 0, "boresightd stopped by SIGINT with exit code 0 (%d)" % rc)
    s = json.load(open(live))
    if s["received"] == 0:
        print("SKIP: nothing arrived on %s in %.1f s of playing (no multicast route on this machine?)" % (url, played_s))
        sys.exit(SKIP)
    rejected = sum(s["rejected"].values()) if isinstance(s["rejected"], dict) else sum(s["rejected"])
    print("sent %d (the replay's count), played in %.1f s; live: received %d, lost %d, used %d, rejected %d"
          % (sent, played_s, s["received"], s["lost"], s["used"], rejected))
    check(s["received"] + s["lost"] == sent, "received + lost == sent (%d + %d, %d)" % (s["received"], s["lost"], sent))
    check(s["received"] == s["used"] + rejected, "received == used + rejected")
    check(s["accounted"], "the node's own accounting holds")
    if s["lost"] == 0:
        check(s["rows"] == r["rows"] and s["published"] == r["published"],
              "no loss: the rows and published messages of the replay (%d / %d, %d / %d)"
              % (s["rows"], r["rows"], s["published"], r["published"]))
finally:
    if node is not None and node.poll() is None:
        node.kill()
    shutil.rmtree(d, ignore_errors=True)

if failures:
    print("%d check(s) failed" % len(failures))
    sys.exit(1)
print("all checks passed")
