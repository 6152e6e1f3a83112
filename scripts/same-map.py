#!/usr/bin/env python3
"""Compares two irradiance.csv files (libimap's map: one row per vertex) number by number:
the same rows and columns, every value within REL (default 1e-12) relative of the other's,
and a map that is not all zero. Line ends are ignored (Windows writes CRLF). Prints the
largest relative difference; exit status 1 when they differ.

    scripts/same-map.py A/irradiance.csv B/irradiance.csv [REL] [WHAT]
"""
import sys


def rows(path):
    with open(path, newline="") as f:
        lines = [l.rstrip("\r\n") for l in f if l.strip()]
    return lines[0], [l.split(",") for l in lines[1:]]


def number(text):
    try:
        return float(text)
    except ValueError:
        return 0.0


def main():
    a, b = sys.argv[1], sys.argv[2]
    rel = float(sys.argv[3]) if len(sys.argv) > 3 else 1e-12
    what = sys.argv[4] if len(sys.argv) > 4 else f"{a} and {b}"
    (ha, ra), (hb, rb) = rows(a), rows(b)
    if ha != hb or len(ra) != len(rb):
        print(f"{what}: different maps ({len(ra)} and {len(rb)} rows; headers {ha!r}, {hb!r})")
        return 1
    worst = 0.0
    for k, (x, y) in enumerate(zip(ra, rb)):
        if len(x) != len(y):
            print(f"{what}: row {k + 2} has {len(x)} and {len(y)} columns")
            return 1
        for p, q in zip(x, y):
            try:
                u, v = float(p), float(q)
            except ValueError:
                if p != q:
                    print(f"{what}: row {k + 2}: {p!r} and {q!r}")
                    return 1
                continue
            scale = max(abs(u), abs(v))
            if scale > 0:
                worst = max(worst, abs(u - v) / scale)
    # A lit map: some value after the mesh, vertex and position columns is positive.
    nonzero = any(number(c) > 0 for r in ra for c in r[5:])
    if worst > rel or not nonzero:
        print(f"{what}: largest relative difference {worst:.3g} (allowed {rel:g}); lit: {nonzero}")
        return 1
    print(f"{what}: {len(ra)} rows equal, largest relative difference {worst:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
