#!/usr/bin/env python3
"""Radiance's reading of an asymmetric Klems BSDF file, for tests/surfaces.rs.

A vertical window (1 m x 1 m, its centre 1.5 m up, in the plane y = 0; the room is y > 0)
of a WINDOW BSDF file that sends all light arriving on its front (WINDOW's front: the
exterior, y < 0) into one Klems patch, theta 40 deg, phi 225 deg, with the up direction
+z. Sunlight arrives along +y (a 2 deg source). Radiance 6.0a (the `pyradiance` wheel on
PyPI bundles it) computes the irradiance on the floor (z = 0) by `rtrace -I`; this script
writes the lit spot's centroid and the floor's total, which the test compares with
libimap's floor under the same file.

Radiance's BSDF primitive has its normal toward WINDOW's back (into the room): the window
polygon here faces +y. libimap's mesh faces the file's front (-y).

Run:  python3 -m venv /tmp/rad && /tmp/rad/bin/pip install pyradiance==1.3.1
      /tmp/rad/bin/python scripts/radiance_klems.py > tests/data/radiance_klems.txt
"""
import math
import os
import subprocess
import sys
import tempfile

import pyradiance

BIN = os.path.join(os.path.dirname(pyradiance.__file__), "bin")
LIB = os.path.join(os.path.dirname(pyradiance.__file__), "lib")
RINGS = [(0, 5, 1), (5, 15, 8), (15, 25, 16), (25, 35, 20), (35, 45, 24), (45, 55, 24),
         (55, 65, 24), (65, 75, 16), (75, 90, 12)]
THETA, PHI = 40.0, 225.0


def patches():
    out = []
    for lo, hi, n in RINGS:
        lam = math.pi * (math.cos(math.radians(lo)) ** 2 - math.cos(math.radians(hi)) ** 2) / n
        for k in range(n):
            out.append((lo, hi, n, k, lam))
    return out


def target(ps):
    for i, (lo, hi, n, k, _) in enumerate(ps):
        if lo <= THETA < hi and k == round(PHI / 360.0 * n) % n:
            return i
    raise SystemExit("no patch")


def xml(ps, o):
    n = len(ps)
    rows = []
    # WINDOW's order (IncidentDataStructure Columns): a row per outgoing patch.
    for out in range(n):
        v = 0.5 / ps[o][4] if out == o else 0.0
        rows.append(", ".join(["%g" % v] * n))
    data = ",\n".join(rows)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<WindowElement xmlns="http://windows.lbl.gov">
<FileType>BSDF</FileType>
<Optical>
<Layer>
<Material><Name>redirect</Name></Material>
<DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure></DataDefinition>
<WavelengthData><LayerNumber>System</LayerNumber><Wavelength unit="Integral">Visible</Wavelength>
<SourceSpectrum>CIE Illuminant D65 1nm.ssp</SourceSpectrum><DetectorSpectrum>ASTM E308 1931 Y.dsp</DetectorSpectrum>
<WavelengthDataBlock><WavelengthDataDirection>Transmission Front</WavelengthDataDirection>
<ColumnAngleBasis>LBNL/Klems Full</ColumnAngleBasis><RowAngleBasis>LBNL/Klems Full</RowAngleBasis>
<ScatteringDataType>BTDF</ScatteringDataType>
<ScatteringData>
{data}
</ScatteringData>
</WavelengthDataBlock>
</WavelengthData>
</Layer>
</Optical>
</WindowElement>
"""


def main():
    ps = patches()
    o = target(ps)
    env = dict(os.environ, PATH=BIN + os.pathsep + os.environ["PATH"], RAYPATH="." + os.pathsep + LIB)
    with tempfile.TemporaryDirectory() as d:
        open(os.path.join(d, "redirect.xml"), "w").write(xml(ps, o))
        # The window faces +y (Radiance's BSDF front, WINDOW's back); up +z.
        scene = """void BSDF redirect
6 0 redirect.xml 0 0 1 .
0
0
redirect polygon window
0
0
12 -0.5 0 1  -0.5 0 2  0.5 0 2  0.5 0 1
void light sunlight
0
0
3 1e5 1e5 1e5
sunlight source sun
0
0
4 0 -1 0 2
"""
        open(os.path.join(d, "scene.rad"), "w").write(scene)
        oct_ = subprocess.run(["oconv", "scene.rad"], cwd=d, env=env, capture_output=True, check=True).stdout
        open(os.path.join(d, "scene.oct"), "wb").write(oct_)
        step = 0.25
        xs = [-3.0 + step * i for i in range(29)]
        ys = [0.125 + step * j for j in range(24)]
        pts = "".join(f"{x} {y} 0.001 0 0 1\n" for y in ys for x in xs)
        r = subprocess.run(
            ["rtrace", "-h", "-I", "-ab", "1", "-ad", "4096", "-as", "0", "-aa", "0", "-lw", "1e-7",
             "-dj", "0", "-ds", "0", "-st", "0", "-ss", "0", "-w", "scene.oct"],
            cwd=d, env=env, input=pts.encode(), capture_output=True, check=True)
        vals = [float(l.split()[1]) for l in r.stdout.decode().splitlines() if l.strip()]
    e = [[vals[j * len(xs) + i] for i in range(len(xs))] for j in range(len(ys))]
    total = sum(sum(row) for row in e)
    cx = sum(e[j][i] * xs[i] for j in range(len(ys)) for i in range(len(xs))) / total
    cy = sum(e[j][i] * ys[j] for j in range(len(ys)) for i in range(len(xs))) / total
    print("# Radiance 6.0a (pyradiance 1.3.1), scripts/radiance_klems.py: the floor under a")
    print(f"# Klems window redirecting everything to theta {THETA} phi {PHI} (up +z), sun along +y.")
    print("# centroid_x centroid_y (m, from the window's centre foot) and the share of the floor")
    print("# points above 5 % of the largest on the x > 0 side")
    big = max(max(row) for row in e)
    lit = [(xs[i], ys[j]) for j in range(len(ys)) for i in range(len(xs)) if e[j][i] > 0.05 * big]
    right = sum(1 for x, _ in lit if x > 0) / len(lit)
    print(f"{cx:.4f} {cy:.4f} {right:.4f}")
    print(f"# grid {len(xs)} x {len(ys)}, step {step} m; lit points {len(lit)}", file=sys.stderr)


if __name__ == "__main__":
    main()
