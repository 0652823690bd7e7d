#!/usr/bin/env python3
"""Mutation harness: damages every input kind of every boresight program and runs it (issue 18).

  test/robustness/mutate.py --build BUILD [--runs N] [--seed S] [--jobs J] [--timeout S] [--mem-mb M]

Inputs are made fresh in a temporary folder (a short simulation, a ground measurement, the platform,
node and scenario files of config/, and the real GRACE-FO samples when ../shared/data/real or
$BORESIGHT_REAL_DATA is there). Each run picks a program, one of its inputs and a mutation:
byte flips, truncation, NaN / Inf / huge values, duplicated and shuffled lines, time tags backwards and
far ahead, the wrong product under the expected name, an empty file, a directory, an endless input
(/dev/zero), an output over an input; then runs the program with a time limit and a memory limit and
checks:
  - no signal (crash, abort, sanitizer report), no hang (the time limit);
  - the exit status is 0, 1 or 2, and a failure names a place (file, or file:line);
  - no half-written output: no temporary file left, an output that existed before a failed run is
    unchanged, and an output of a successful run is complete (CSV rows of one width ending in a
    newline, JSON that parses);
  - no exit 0 on garbage without a warning (an empty, endless or wrong input, or a value that cannot
    be, must be rejected or refused where it is seen);
  - every count adds up (read = used + rejected per file and in total; the node's received = used +
    rejected).
Prints one line per finding and a summary; exit status 0 when there is none. The same --seed gives
the same runs.
"""
import argparse
import json
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.abspath(os.path.join(HERE, "..", ".."))

# ---------------------------------------------------------------------------------------------------
# inputs


def run_quiet(cmd, **kw):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors="replace", **kw)
    if r.returncode != 0:
        raise RuntimeError("setup failed: %s\n%s" % (" ".join(cmd), r.stdout))
    return r.stdout


def make_inputs(work, cli, duration):
    """The clean inputs: {kind: path}."""
    sim = os.path.join(work, "sim")
    run_quiet([cli, "simulate", "--scenario", os.path.join(SRC, "config/sim_gracefo_calibration_short.yaml"),
               "--seed", "1", "--duration", str(duration), "--out", sim, "--quiet"])
    inp = {
        "sca1a": os.path.join(sim, "SCA1A_2023-06-01_C_04.txt"),
        "acc1a": os.path.join(sim, "ACC1A_2023-06-01_C_04.txt"),
        "qsa1b": os.path.join(sim, "QSA1B_2023-06-01_C_04.txt"),
        "gnv1b": os.path.join(sim, "GNV1B_2023-06-01_C_04.txt"),
        "lcm": os.path.join(sim, "sim.lcmlog"),
    }
    ground = os.path.join(work, "ground.yaml")
    run_quiet([cli, "simulate-ground", "--seed", "1", "--targets", "12", "--accel-samples", "50", "--out", ground])
    inp["ground"] = ground
    # configuration files, with absolute paths where they name other files
    # the platform file of simulated data (the ideal noise preset), its base named absolutely
    inp["platform"] = os.path.join(work, "gracefo_ideal.yaml")
    platform = open(os.path.join(SRC, "config/gracefo_ideal.yaml")).read()
    platform = re.sub(r"(?m)^base:.*$", "base: " + os.path.join(SRC, "config/gracefo.yaml"), platform)
    open(inp["platform"], "w").write(platform)
    node = open(os.path.join(SRC, "config/boresightd.yaml")).read()
    node = re.sub(r"(?m)^platform:.*$", "platform: " + inp["platform"], node)
    node = re.sub(r"(?m)^(\s*)cadence_s:.*$", r"\1cadence_s: 300", node)
    node = re.sub(r"(?m)^(\s*)min_span_s:.*$", r"\1min_span_s: 300", node)
    node = re.sub(r"(?m)^(\s*)apply_lag_epochs:.*$", r"\1apply_lag_epochs: 20", node)
    inp["node"] = os.path.join(work, "boresightd.yaml")
    open(inp["node"], "w").write(node)
    scenario = open(os.path.join(SRC, "config/sim_gracefo_calibration_short.yaml")).read()
    scenario = re.sub(r"(?m)^base:.*$", "base: " + os.path.join(SRC, "config/sim_gracefo_calibration.yaml"), scenario)
    inp["scenario"] = os.path.join(work, "scenario.yaml")
    open(inp["scenario"], "w").write(scenario)
    # a CSV of process for plot
    csv = os.path.join(work, "rows.csv")
    run_quiet([cli, "process", "--config", inp["platform"], inp["sca1a"], inp["acc1a"], inp["qsa1b"], "--out", csv])
    inp["csv"] = csv
    # a model overlay (io/overlay_yaml.h) as `boresight noise` writes one: noise of every head axis and
    # of the accelerometer
    noise = os.path.join(work, "noise")
    run_quiet([cli, "noise", "--quiet", "--config", inp["platform"], inp["sca1a"], inp["acc1a"], inp["qsa1b"], "--out",
               noise])
    inp["overlay"] = os.path.join(noise, "overlay.yaml")
    # the real samples, when present
    real = os.environ.get("BORESIGHT_REAL_DATA", os.path.join(SRC, "..", "shared", "data", "real"))
    l1a = os.path.join(real, "gracefo", "2023-06-01_L1A")
    if os.path.isdir(l1a):
        inp["real_sca1a"] = os.path.join(l1a, "SCA1A_2023-06-01_C_04.txt")
        inp["real_acc1a"] = os.path.join(l1a, "ACC1A_2023-06-01_C_04.txt")
        inp["real_qsa1b"] = os.path.join(real, "gracefo", "static_2018-05-22", "QSA1B_2018-05-22_C_04.txt")
    return inp


# ---------------------------------------------------------------------------------------------------
# mutations: (name, garbage?) -> function(src_bytes, rng) -> bytes, or a special marker

TEXT_KINDS = {"sca1a", "acc1a", "qsa1b", "gnv1b", "real_sca1a", "real_acc1a", "real_qsa1b"}
YAML_KINDS = {"platform", "node", "scenario", "ground", "overlay"}


def split_body(text):
    """(header, data lines) of a Level-1 text."""
    for marker in ("# End of YAML header\n",):
        i = text.find(marker)
        if i >= 0:
            return text[: i + len(marker)], text[i + len(marker):].splitlines(True)
    i = text.rfind("END OF HEADER")
    if i >= 0:
        j = text.find("\n", i) + 1
        return text[:j], text[j:].splitlines(True)
    return "", text.splitlines(True)


NUM = re.compile(r"(?<![\w.])-?\d+\.?\d*(?:[eE][-+]?\d+)?(?![\w.])")


def m_flip(b, rng):
    b = bytearray(b)
    for _ in range(rng.randint(1, 8)):
        if b:
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
    return bytes(b)


def m_truncate(b, rng):
    return b[: rng.randrange(max(1, len(b)))]


# The columns (0-based, whitespace-separated) of the physical values each Level-1 product's readers gate:
# a huge value there must be rejected; elsewhere (counters, the QSA1B zero column, GNV1B's 1e33 "no
# error" convention) it may be a legal number.
GATED = {"SCA1A": [5, 6, 7, 8], "ACC1A": [6, 7, 8, 9, 10, 11], "GNV1B": [3, 4, 5, 9, 10, 11], "QSA1B": [3, 4, 5, 6]}


def m_value(b, rng, value, product=None):
    t = b.decode("latin-1")
    head, lines = split_body(t)
    if not lines:
        return b
    k = rng.randrange(len(lines))
    nums = list(NUM.finditer(lines[k]))
    if product is not None:
        fields = list(re.finditer(r"\S+", lines[k]))
        nums = [fields[c] for c in GATED.get(product, []) if c < len(fields)]
    if not nums:
        return b
    m = nums[rng.randrange(len(nums))]
    lines[k] = lines[k][: m.start()] + value + lines[k][m.end():]
    return (head + "".join(lines)).encode("latin-1")


def m_dup(b, rng):
    t = b.decode("latin-1")
    head, lines = split_body(t)
    if not lines:
        return b
    k = rng.randrange(len(lines))
    lines[k:k] = [lines[k]] * rng.randint(1, 3)
    return (head + "".join(lines)).encode("latin-1")


def m_shuffle(b, rng):
    t = b.decode("latin-1")
    head, lines = split_body(t)
    if len(lines) < 3:
        return b
    i = rng.randrange(len(lines) - 2)
    w = lines[i: i + rng.randint(2, 40)]
    rng.shuffle(w)
    lines[i: i + len(w)] = w
    return (head + "".join(lines)).encode("latin-1")


def m_tag(b, rng):
    """A record's time tag (its first field) far ahead, a day ahead, or backwards."""
    t = b.decode("latin-1")
    head, lines = split_body(t)
    if not lines:
        return b
    k = rng.randrange(len(lines))
    f = lines[k].split(" ")
    try:
        v = int(f[0])
    except ValueError:
        return b
    f[0] = str(v + rng.choice([100000000, 86400, -700, -100000000, 3]))
    lines[k] = " ".join(f)
    return (head + "".join(lines)).encode("latin-1")


def m_yaml_dup(b, rng):
    lines = b.decode("latin-1").splitlines(True)
    keyed = [i for i, l in enumerate(lines) if re.match(r"^\s*\w+:\s*\S", l)]
    if not keyed:
        return b
    i = rng.choice(keyed)
    lines.insert(i + 1, lines[i])
    return "".join(lines).encode("latin-1")


def m_yaml_value(b, rng):
    lines = b.decode("latin-1").splitlines(True)
    num = [i for i, l in enumerate(lines) if re.match(r"^\s*-?\s*\w+:\s*-?\d", l)]
    if not num:
        return b
    i = rng.choice(num)
    lines[i] = re.sub(r":\s*-?[\d.eE+-]+", ": " + rng.choice([".nan", ".inf", "-1e308", "1e-300", "0", "-1"]), lines[i], 1)
    return "".join(lines).encode("latin-1")


# name -> (function or marker, garbage, applicable kinds (None: all))
MUTATIONS = {
    "flip": (m_flip, False, None),
    "truncate": (m_truncate, False, None),
    "nan": (lambda b, r: m_value(b, r, r.choice(["nan", "NaN", "-nan"])), True, TEXT_KINDS),
    "inf": (lambda b, r: m_value(b, r, r.choice(["inf", "-inf", "1e999"])), True, TEXT_KINDS),
    "huge": ("HUGE", True, TEXT_KINDS),
    "dup_lines": (m_dup, False, TEXT_KINDS | {"csv"}),
    "shuffle_lines": (m_shuffle, False, TEXT_KINDS | {"csv"}),
    "tag": (m_tag, False, TEXT_KINDS - {"qsa1b", "real_qsa1b"}),
    "yaml_dup_key": (m_yaml_dup, True, YAML_KINDS),
    "yaml_value": (m_yaml_value, False, YAML_KINDS),
    "wrong_product": ("WRONG", True, None),
    "empty": ("EMPTY", True, None),
    "directory": ("DIR", True, None),
    "endless": ("ENDLESS", True, None),
    "output_over_input": ("OVER", True, None),
}

# ---------------------------------------------------------------------------------------------------
# programs: name -> (inputs used, command builder)


def commands(inp):
    """program -> (list of input kinds it reads, builder(paths, outdir) -> (argv, outputs))."""
    p = {}

    def process(x, o):
        return (["process", "--config", x["platform"], x["sca1a"], x["acc1a"], x["qsa1b"], "--out", o + "/rows.csv"],
                [o + "/rows.csv"])
    p["process"] = (["platform", "sca1a", "acc1a", "qsa1b"], process)

    def process_lcm(x, o):
        return (["process", "--config", x["platform"], x["lcm"], x["qsa1b"], "--out", o + "/rows.csv"], [o + "/rows.csv"])
    p["process_lcm"] = (["lcm", "qsa1b"], process_lcm)

    def calibrate(x, o):
        return (["calibrate", "--config", x["platform"], x["sca1a"], x["acc1a"], x["qsa1b"], x["gnv1b"], "--json",
                 o + "/cal.json", "--write-model", o + "/model.yaml"], [o + "/cal.json", o + "/model.yaml"])
    p["calibrate"] = (["platform", "sca1a", "acc1a", "qsa1b", "gnv1b"], calibrate)

    def calibrate_overlay(x, o):
        return (["calibrate", "--config", x["platform"], "--overlay", x["overlay"], x["sca1a"], x["acc1a"], x["qsa1b"],
                 "--json", o + "/cal.json"], [o + "/cal.json"])
    p["calibrate_overlay"] = (["overlay", "sca1a", "acc1a"], calibrate_overlay)

    def process_overlay(x, o):
        return (["process", "--config", x["platform"], "--overlay", x["overlay"], x["sca1a"], x["acc1a"], x["qsa1b"],
                 "--out", o + "/rows.csv"], [o + "/rows.csv"])
    p["process_overlay"] = (["overlay", "platform"], process_overlay)

    def noise(x, o):
        return (["noise", "--config", x["platform"], "--overlay", x["overlay"], x["sca1a"], x["acc1a"],
                 x["qsa1b"], "--out", o + "/noise"], [o + "/noise/noise.json", o + "/noise/overlay.yaml"])
    p["noise"] = (["platform", "overlay", "sca1a", "acc1a", "qsa1b"], noise)

    def audit(x, o):
        return (["audit", "--quiet", "--config", x["platform"], "--overlay", x["overlay"], x["sca1a"], x["acc1a"],
                 x["qsa1b"], "--out", o + "/audit"], [o + "/audit/audit.json"])
    p["audit"] = (["platform", "overlay", "sca1a", "acc1a", "qsa1b"], audit)

    def inspect(x, o):
        return (["inspect", x["sca1a"], x["acc1a"], x["qsa1b"], x["gnv1b"], x["lcm"], "--json", o + "/i.json"],
                [o + "/i.json"])
    p["inspect"] = (["sca1a", "acc1a", "qsa1b", "gnv1b", "lcm"], inspect)

    def convert(x, o):
        return (["convert", x["sca1a"], x["acc1a"], x["qsa1b"], x["gnv1b"], "--out", o + "/c.lcm"], [o + "/c.lcm"])
    p["convert"] = (["sca1a", "acc1a", "qsa1b", "gnv1b"], convert)

    def convert_back(x, o):
        return (["convert", x["lcm"], "--to-level1", o + "/l1"], [])
    p["convert_back"] = (["lcm"], convert_back)

    def ground(x, o):
        return (["ground", "--input", x["ground"], "--json", o + "/g.json"], [o + "/g.json"])
    p["ground"] = (["ground"], ground)

    def simulate(x, o):
        return (["simulate", "--scenario", x["scenario"], "--seed", "2", "--duration", "30", "--quiet", "--out",
                 o + "/sim"], [o + "/sim/truth.yaml"])
    p["simulate"] = (["scenario"], simulate)

    def plot(x, o):
        return (["plot", x["csv"], "--y", "w_x,iba_12_dev_arcsec", "--out", o + "/p.svg"], [o + "/p.svg"])
    p["plot"] = (["csv"], plot)

    def node(x, o):
        return (["@boresightd", "--config", x["node"], "--replay", x["lcm"], "--summary-json", o + "/s.json", "--csv",
                 o + "/n.csv"], [o + "/s.json", o + "/n.csv"])
    p["boresightd"] = (["node", "lcm"], node)

    if "real_sca1a" in inp:
        def real(x, o):
            return (["process", "--config", x["platform"], x["real_sca1a"], x["real_acc1a"], x["real_qsa1b"], "--out",
                     o + "/rows.csv"], [o + "/rows.csv"])
        p["process_real"] = (["platform", "real_sca1a", "real_acc1a", "real_qsa1b"], real)
    return p


# ---------------------------------------------------------------------------------------------------
# checks

PLACE = re.compile(r"(/[^\s:]+|[\w.-]+\.(yaml|txt|lcm|lcmlog|csv|json|svg)|--[\w-]+)")
SOURCE_LINE = re.compile(r"^(\S+): (\d+) read, (\d+) used((?:, \d+ [^,\n]+)*)$", re.M)
TOTAL_LINE = re.compile(r"inputs: (\d+) read = (\d+) used .* \+ (\d+) rejected")


DAMAGE = re.compile(r", [1-9]\d* [a-z]|rejected|implausible|outlier|duplicate|ignored|error|not a|late|malformed",
                    re.I)


def damage_reported(out, target):
    """A line about the damaged file that says something was wrong with it."""
    base = os.path.basename(target)
    return any(base in line and DAMAGE.search(line) for line in out.splitlines())


def check_counts(out):
    bad = []
    for m in SOURCE_LINE.finditer(out):
        read, used = int(m.group(2)), int(m.group(3))
        rej = sum(int(x) for x in re.findall(r", (\d+) ", m.group(4)))
        if read != used + rej:
            bad.append("counts of %s: %d read != %d used + %d rejected" % (m.group(1), read, used, rej))
    for m in TOTAL_LINE.finditer(out):
        if int(m.group(1)) != int(m.group(2)) + int(m.group(3)):
            bad.append("total counts: " + m.group(0))
    return bad


def check_output(path):
    """A complete output (after exit 0): CSV rows of one width ending in a newline, JSON that parses."""
    if not os.path.exists(path):
        return None
    if os.path.isdir(path):
        return None
    data = open(path, "rb").read()
    if path.endswith(".json"):
        try:
            json.loads(data.decode("utf-8", "replace"))
        except ValueError as e:
            return "%s: not complete JSON (%s)" % (path, e)
    elif path.endswith(".csv"):
        if data and not data.endswith(b"\n"):
            return "%s: cut mid-line" % path
        widths = {l.count(b",") for l in data.splitlines() if l}
        if len(widths) > 1:
            return "%s: rows of several widths %s" % (path, sorted(widths))
    return None


def temporaries(folder):
    found = []
    for root, _, files in os.walk(folder):
        found += [os.path.join(root, f) for f in files if ".tmp-" in f]
    return found


# ---------------------------------------------------------------------------------------------------


CATEGORIES = ["crash", "hang", "half-written output", "unaccounted records", "exit 0 on garbage",
              "failure without a place", "other"]


def category(f):
    """The summary's kind of a finding."""
    if f.startswith("signal") or f.startswith("exit status") or f.startswith("sanitizer"):
        return "crash"
    if f.startswith("hang"):
        return "hang"
    if "temporary files" in f or "changed by a failed run" in f or "cut mid-line" in f or "not complete" in f \
            or "several widths" in f or "summary unreadable" in f:
        return "half-written output"
    if "counts" in f:
        return "unaccounted records"
    if f.startswith("exit 0 on"):
        return "exit 0 on garbage"
    if f.startswith("a failure without a place"):
        return "failure without a place"
    return "other"


def one_run(k, args, clean, progs, rng_seed):
    rng = random.Random(rng_seed)
    prog = rng.choice(sorted(progs))
    kinds, build = progs[prog]
    kind = rng.choice(kinds)
    names = [n for n, (_, _, applies) in MUTATIONS.items() if applies is None or kind in applies]
    mut = rng.choice(names)
    fn, garbage, _ = MUTATIONS[mut]
    run_dir = os.path.join(args.work, "run%06d" % k)
    in_dir, out_dir = os.path.join(run_dir, "in"), os.path.join(run_dir, "out")
    os.makedirs(in_dir)
    os.makedirs(out_dir)
    paths = dict(clean)
    # The damaged input keeps its file name (products are recognised by name and content).
    target = os.path.join(in_dir, os.path.basename(clean[kind]))
    sentinel = None
    if fn == "DIR":
        os.makedirs(target)
    elif fn == "ENDLESS":
        os.symlink("/dev/zero", target)
    elif fn == "EMPTY":
        open(target, "wb").close()
    elif fn == "WRONG":
        others = [v for kk, v in clean.items() if kk != kind and os.path.isfile(v) and
                  os.path.basename(v)[:5] != os.path.basename(clean[kind])[:5]]
        shutil.copy(rng.choice(others), target)
    else:
        src = open(clean[kind], "rb").read()
        if fn == "OVER":
            shutil.copy(clean[kind], target)
        elif fn == "HUGE":  # in a column whose physical value the readers gate
            data = m_value(src, rng, rng.choice(["1e308", "-1e308", "1e30", "99999999999"]), os.path.basename(target)[:5])
            garbage = data != src
            open(target, "wb").write(data)
        else:
            data = fn(src, rng)
            garbage = garbage and data != src
            open(target, "wb").write(data)
    paths[kind] = target
    argv, outputs = build(paths, out_dir)
    if fn == "OVER":
        # the first output named as the damaged input: the input must survive untouched
        if outputs and outputs[0] in argv:
            o = outputs[0]
            argv = [target if a == o else a for a in argv]
            outputs = []
            sentinel = (target, open(target, "rb").read())
        else:
            garbage = False  # the program names no output file it could be pointed at: a clean run
    elif outputs and rng.random() < 0.5:
        # an existing output: a failed run must leave it as it was
        os.makedirs(os.path.dirname(outputs[0]), exist_ok=True)
        open(outputs[0], "wb").write(b"previous\n")
        sentinel = (outputs[0], b"previous\n")
    exe = args.boresightd if argv[0] == "@boresightd" else args.cli
    argv = [exe] + (argv[1:] if argv[0] == "@boresightd" else argv)

    def limits():
        if args.mem_mb > 0:
            resource.setrlimit(resource.RLIMIT_AS, (args.mem_mb << 20, args.mem_mb << 20))
        os.setsid()

    t0 = time.time()
    findings = []
    try:
        p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, preexec_fn=limits, cwd=run_dir)
        try:
            raw, _ = p.communicate(timeout=args.timeout)
            rc = p.returncode
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            raw, _ = p.communicate()
            rc = None
    except OSError as e:
        return (k, prog, kind, mut, -99, ["could not run: %s" % e], 0.0)
    out = raw.decode("utf-8", "replace")
    dt = time.time() - t0
    if rc is None:
        findings.append("hang (no exit in %g s)" % args.timeout)
    elif rc < 0:
        findings.append("signal %d (%s)" % (-rc, signal.Signals(-rc).name if -rc in signal.valid_signals() else "?"))
    elif rc not in (0, 1, 2):
        findings.append("exit status %d" % rc)
    if "AddressSanitizer" in out or "runtime error:" in out or "LeakSanitizer" in out:
        findings.append("sanitizer report")
    if rc in (1, 2) and not PLACE.search(out):
        findings.append("a failure without a place (file or option)")
    if prog == "inspect" and mut == "wrong_product":
        garbage = False  # inspect recognises products by content: another product is a valid input there
    if rc == 0 and garbage:
        if kind in YAML_KINDS:
            findings.append("exit 0 on a garbage configuration file (%s)" % mut)
        elif prog == "boresightd":
            try:
                sj = json.load(open(os.path.join(out_dir, "s.json")))
                if sum(sj["rejected"].values()) == 0 and sj["lost"] == 0:
                    findings.append("exit 0 on a garbage log (%s) with nothing rejected" % mut)
            except (OSError, ValueError, KeyError):
                pass  # reported below
        elif not damage_reported(out, target):
            findings.append("exit 0 on garbage (%s) without a word about %s" % (mut, os.path.basename(target)))
    if rc is not None and rc >= 0:
        findings += check_counts(out)
        left = temporaries(run_dir)
        if left:
            findings.append("temporary files left: %s" % ", ".join(left[:3]))
        # (inspect writes its JSON also when a file could not be read, exit 1: checked complete below)
        if sentinel and ((rc != 0 and prog != "inspect") or fn == "OVER"):
            path, before = sentinel
            now = open(path, "rb").read() if os.path.isfile(path) else None
            if now != before:
                findings.append("%s changed by a failed run (or an output over an input)" % path)
        if rc == 0 or prog == "inspect":
            for o in outputs:
                e = check_output(o)
                if e:
                    findings.append(e)
    if prog == "boresightd" and rc == 0:
        try:
            s = json.load(open(os.path.join(out_dir, "s.json")))
            rej = sum(s["rejected"].values())
            if s["received"] != s["used"] + rej or not s.get("accounted", False):
                findings.append("node counts: received %d != used %d + rejected %d" % (s["received"], s["used"], rej))
        except (OSError, ValueError, KeyError) as e:
            findings.append("node summary unreadable after exit 0: %s" % e)
    if findings and args.keep_failures:
        open(os.path.join(run_dir, "output.txt"), "w").write(" ".join(argv) + "\n\n" + out)
    else:
        shutil.rmtree(run_dir, ignore_errors=True)
    return (k, prog, kind, mut, rc, findings, dt)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", required=True, help="build folder with tools/boresight and tools/boresightd")
    ap.add_argument("--runs", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per run (a hang)")
    ap.add_argument("--mem-mb", type=int, default=3072, help="address-space limit per run, MiB (0: none; sanitizers)")
    ap.add_argument("--duration", type=int, default=900,
                    help="simulated seconds of the clean inputs (900: calibrate and the node's worker solve)")
    ap.add_argument("--work", help="folder for the runs (default: a temporary one, removed)")
    ap.add_argument("--keep-failures", action="store_true", help="keep the folders of runs with findings")
    ap.add_argument("--src", help="source tree whose config/ files to use (default: this one)")
    args = ap.parse_args()
    if args.src:
        global SRC
        SRC = os.path.abspath(args.src)
    args.cli = os.path.abspath(os.path.join(args.build, "tools", "boresight"))
    args.boresightd = os.path.abspath(os.path.join(args.build, "tools", "boresightd"))
    if not os.access(args.cli, os.X_OK):
        print("no %s: build the boresight target first" % args.cli, file=sys.stderr)
        return 2
    own_work = args.work is None
    args.work = tempfile.mkdtemp(prefix="boresight-mutate-") if own_work else os.path.abspath(args.work)
    os.makedirs(args.work, exist_ok=True)
    t0 = time.time()
    try:
        clean = make_inputs(os.path.join(args.work, "clean"), args.cli, args.duration)
        progs = commands(clean)
        if not os.access(args.boresightd, os.X_OK):
            progs.pop("boresightd")
        master = random.Random(args.seed)
        seeds = [master.getrandbits(64) for _ in range(args.runs)]
        results = []
        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            for r in pool.map(lambda kv: one_run(kv[0], args, clean, progs, kv[1]), enumerate(seeds)):
                results.append(r)
                k, prog, kind, mut, rc, findings, dt = r
                for f in findings:
                    print("FINDING run %d: %s, %s damaged by %s (exit %s): %s" % (k, prog, kind, mut, rc, f), flush=True)
    finally:
        if own_work and not args.keep_failures:
            shutil.rmtree(args.work, ignore_errors=True)
    by_rc, by_prog = {}, {}
    for r in results:
        by_rc[r[4]] = by_rc.get(r[4], 0) + 1
        by_prog[r[1]] = by_prog.get(r[1], 0) + 1
    n_find = sum(1 for r in results if r[5])
    cats = {c: 0 for c in CATEGORIES}
    for r in results:
        for f in r[5]:
            cats[category(f)] += 1
    slow = max(results, key=lambda r: r[6])
    print("mutation harness: %d runs (seed %d) of %d programs x %d mutations in %.0f s: exit 0: %d, 1: %d, 2: %d; "
          "runs with findings: %d; slowest run %.1f s (%s, %s)" %
          (len(results), args.seed, len(progs), len(MUTATIONS), time.time() - t0, by_rc.get(0, 0), by_rc.get(1, 0),
           by_rc.get(2, 0), n_find, slow[6], slow[1], slow[3]))
    print("findings by kind: " + ", ".join("%s %d" % (c, cats[c]) for c in CATEGORIES))
    print("runs per program: " + ", ".join("%s %d" % kv for kv in sorted(by_prog.items())))
    return 1 if n_find else 0


if __name__ == "__main__":
    sys.exit(main())
