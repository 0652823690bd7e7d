#!/usr/bin/env python3
"""Reference point for the parse benchmark: pandas' C parser on the same generated full-day files.

usage: tools/bench_parse_pandas.py FILE... [--repeat N]
Prints MB/s per file: best of N runs and the range, and the peak RSS of this process. Every field is
parsed: the numeric columns as float64 (a malformed number makes the column fail as it would for
pandas' users), ids and bit strings as text. Needs pandas (pip install pandas)."""
import sys
import time


def header_lines(path):
    n = 0
    with open(path, "rb") as f:
        for line in f:
            n += 1
            s = line.strip()
            if s == b"# End of YAML header" or s.startswith(b"END OF HEADER"):
                return n
    raise SystemExit(f"{path}: no header end found")


def main(argv):
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__)
        return 0 if argv else 2
    repeat = 3
    if "--repeat" in argv:
        i = argv.index("--repeat")
        repeat = int(argv[i + 1])
        del argv[i:i + 2]
    try:
        import pandas as pd
    except ImportError:
        print("pandas not installed: pip install pandas", file=sys.stderr)
        return 1
    import os
    for path in argv:
        skip = header_lines(path)
        size = os.path.getsize(path)
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            # Text columns (ids, bit strings) as strings, numbers as float64; C engine.
            df = pd.read_csv(path, sep=r"\s+", header=None, skiprows=skip, engine="c",
                             dtype={2: str, 3: str, 4: str, 5: str, 14: str, 15: str})
            times.append(time.perf_counter() - t0)
        best, worst = min(times), max(times)
        import resource
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"pandas {pd.__version__} C parser: {os.path.basename(path)}: {len(df)} rows, "
              f"{size / 1e6:.1f} MB, {best:.2f}-{worst:.2f} s, {size / 1e6 / worst:.0f}-{size / 1e6 / best:.0f} MB/s "
              f"({repeat} runs), peak RSS so far {rss:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
