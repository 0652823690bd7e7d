#!/usr/bin/env python3
"""Decodes an LCM log of boresight's messages (boresightd's inputs or its --record output) in plain Python.

Needs only the generated Python types (lcm-gen --python; the build puts them in
build/src/lcmtypes/gen/python, `cmake --install` in share/boresight/python), not LCM's Python module:
the log file is read here. Each event is matched to a type by its fingerprint (the first 8 bytes), so a
channel renamed in the node's configuration still decodes. A message written with another layout of a
type (an older or newer boresight; src/lcmtypes/versions.txt lists every layout's fingerprint) is
counted under its type and version, not decoded: its fields are not this build's.

  tools/lcm_decode.py --types DIR LOG                 counts per channel and type
  tools/lcm_decode.py --types DIR LOG --dump N        and the first N messages of each channel (JSON lines)
  tools/lcm_decode.py --types DIR LOG --json FILE     counts and every message's fields as JSON
  --versions FILE   the versions table (default: versions.txt beside the types, or src/lcmtypes/ of
                    this source tree)

Exit status: 0 read to the end; 1 a damaged log (offset and reason) or a message that does not decode;
2 usage error; 3 read to the end, with messages of other layouts of the types (named) not decoded.
"""
import argparse
import importlib
import json
import os
import struct
import sys

SYNC = 0xEDA1DA01
HEADER = struct.Struct(">IqqII")  # sync, event number, timestamp (us), channel length, data length


def load_types(types_dir):
    sys.path.insert(0, types_dir)
    try:
        pkg = importlib.import_module("boresight_lcm")
    except ImportError as e:
        sys.exit("lcm_decode: no boresight_lcm package under %s (%s)" % (types_dir, e))
    by_fp = {}
    for name in dir(pkg):
        cls = getattr(pkg, name)
        if isinstance(cls, type) and hasattr(cls, "_get_packed_fingerprint"):
            by_fp[cls._get_packed_fingerprint()] = cls
    return by_fp


def load_versions(path):
    """fingerprint (8 bytes) -> (type, version, current) from versions.txt."""
    rows = []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if not parts or parts[0].startswith("#"):
                continue
            rows.append((parts[0], int(parts[1]), bytes.fromhex(parts[2])))
    newest = {}
    for t, v, _fp in rows:
        newest[t] = max(newest.get(t, 0), v)
    return {fp: (t, v, v == newest[t]) for t, v, fp in rows}


def find_versions(types_dir, given):
    if given:
        return given
    here = os.path.dirname(os.path.abspath(__file__))
    for c in (os.path.join(types_dir, "versions.txt"), os.path.join(here, "..", "src", "lcmtypes", "versions.txt")):
        if os.path.exists(c):
            return c
    return None


def events(path):
    """(channel, timestamp, data) per event; raises ValueError with the offset on damage."""
    with open(path, "rb") as f:
        blob = f.read()
    off = 0
    while off < len(blob):
        if len(blob) - off < HEADER.size:
            raise ValueError("offset %d: %d bytes left, not a whole event header" % (off, len(blob) - off))
        sync, _num, ts, clen, dlen = HEADER.unpack_from(blob, off)
        if sync != SYNC:
            raise ValueError("offset %d: sync word 0x%08x, expected 0x%08x" % (off, sync, SYNC))
        start = off + HEADER.size
        end = start + clen + dlen
        if end > len(blob):
            raise ValueError("offset %d: the event runs past the end of the file" % off)
        channel = blob[start:start + clen].decode("utf-8", "replace")
        yield channel, ts, blob[start + clen:end]
        off = end


def fields(msg):
    return {k: getattr(msg, k) for k in msg.__slots__}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log")
    ap.add_argument("--types", required=True, help="directory holding the generated boresight_lcm package")
    ap.add_argument("--dump", type=int, default=0, help="print the first N messages of each channel")
    ap.add_argument("--json", help="write counts and all messages to this file")
    ap.add_argument("--versions", help="versions.txt (every layout of the types)")
    a = ap.parse_args()
    by_fp = load_types(a.types)
    vpath = find_versions(a.types, a.versions)
    versions = load_versions(vpath) if vpath else {}
    counts, unknown, other, out, dumped = {}, {}, {}, {}, {}
    try:
        for ch, ts, data in events(a.log):
            cls = by_fp.get(data[:8])
            if cls is None:
                v = versions.get(data[:8])
                if v is not None:  # another layout of a boresight type
                    other[(ch, v[0], v[1])] = other.get((ch, v[0], v[1]), 0) + 1
                else:
                    unknown[ch] = unknown.get(ch, 0) + 1
                continue
            try:
                msg = cls.decode(data)
            except Exception as e:  # a message of a known type that does not decode
                sys.exit("lcm_decode: %s: channel %s: %s does not decode: %s" % (a.log, ch, cls.__name__, e))
            key = (ch, cls.__name__)
            counts[key] = counts.get(key, 0) + 1
            if a.json:
                out.setdefault(ch, []).append(fields(msg))
            if dumped.get(ch, 0) < a.dump:
                dumped[ch] = dumped.get(ch, 0) + 1
                print(json.dumps({"channel": ch, "type": cls.__name__, "log_utime": ts, **fields(msg)}))
    except ValueError as e:
        sys.exit("lcm_decode: %s: %s" % (a.log, e))
    for (ch, t), n in sorted(counts.items()):
        print("%-24s %-22s %d" % (ch, t, n))
    current = {t: v for (t, v, cur) in versions.values() if cur}
    for (ch, t, v), n in sorted(other.items()):
        print("%-24s %-22s %d   (version %d of the type; these types are version %d: not decoded)"
              % (ch, t, n, v, current.get(t, 0)))
    for ch, n in sorted(unknown.items()):
        print("%-24s %-22s %d" % (ch, "(not a boresight type)", n))
    if other:
        print("lcm_decode: %s: %d messages of other layouts of the types (decode them with the types of the "
              "boresight version that wrote the log)" % (a.log, sum(other.values())), file=sys.stderr)
    if a.json:
        summary = {"counts": {ch: n for (ch, _t), n in counts.items()}, "unknown": unknown,
                   "other_versions": [{"channel": ch, "type": t, "version": v, "count": n}
                                      for (ch, t, v), n in sorted(other.items())],
                   "messages": out}
        with open(a.json, "w") as f:
            json.dump(summary, f)
    return 3 if other else 0


if __name__ == "__main__":
    sys.exit(main())
