#!/usr/bin/env python3
"""Writes src/scene/metals.rs: the complex refractive index n + ik of aluminium, silver,
gold, copper and chromium between 300 and 890 nm, as measured.

Source of the numbers: the luxpop.com optical-constants database, which collects
E. D. Palik (ed.), Handbook of Optical Constants of Solids, Academic Press 1985 (Al, Ag, Au,
Cu; Cr concatenates LLNL/CXRO and Palik), in the copy Mitsuba 3 distributes as
`mitsuba/data/ior/<metal>.{eta,k}.spd` (pip install mitsuba==3.9.1). The values are
copied unchanged (wavelengths rounded to 0.001 nm, n and k to 6 significant digits).

Usage: python3 scripts/metals.py [DATA_DIR] > src/scene/metals.rs
"""
import os
import sys


def read(path):
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            nm, v = line.split()[:2]
            rows.append((float(nm), float(v)))
    return rows


def lit(x):
    s = f"{x:.6g}"
    return s if any(c in s for c in ".e") else s + ".0"


def main():
    if len(sys.argv) > 1:
        data = sys.argv[1]
    else:
        import mitsuba

        data = os.path.join(os.path.dirname(mitsuba.__file__), "data", "ior")
    metals = [("ALUMINIUM", "Al"), ("SILVER", "Ag"), ("GOLD", "Au"), ("COPPER", "Cu"), ("CHROMIUM", "Cr")]
    out = [
        "//! The complex refractive index n + ik of five metals, (nm, n, k), written by",
        "//! `scripts/metals.py` (do not edit). Source: the luxpop.com optical-constants database",
        "//! (E. D. Palik, Handbook of Optical Constants of Solids, 1985; chromium with LLNL/CXRO",
        "//! data below 300 nm), as distributed with Mitsuba 3.9.1 (`data/ior`).",
        "",
        "#![allow(clippy::approx_constant)] // measured values, not constants",
        "",
    ]
    for name, sym in metals:
        eta = read(os.path.join(data, sym + ".eta.spd"))
        k = dict(read(os.path.join(data, sym + ".k.spd")))
        rows = [(nm, n, k[nm]) for nm, n in eta if 290.0 <= nm <= 900.0 and nm in k]
        out.append(f"/// {sym}: {len(rows)} wavelengths, {rows[0][0]:.1f} to {rows[-1][0]:.1f} nm.")
        out.append(f"pub const {name}: &[[f64; 3]] = &[")
        for nm, n, kk in rows:
            out.append(f"    [{nm:.3f}, {lit(n)}, {lit(kk)}],")
        out.append("];")
        out.append("")
    sys.stdout.write("\n".join(out).rstrip() + "\n")


main()
