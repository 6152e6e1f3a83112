#!/usr/bin/env python3
"""Radiance's Perez all-weather skies, for the tests of src/scene/light/perez.rs.

For each case (a date, an hour of local standard time, a site, the direct normal and the
diffuse horizontal irradiance in W/m2) Radiance 6.0a's gendaylit (the `pyradiance` wheel on
PyPI bundles it) makes the Perez sky. This script writes what gendaylit computed (the sun's
direction, the clearness and brightness, the five Perez parameters a-e, the sun's radiance)
and what its sky gives: the diffuse horizontal illuminance measured by rtrace -I at an open
horizontal point under the sky alone (-ab 1, 65536 ambient divisions, no caching), and the
sky's luminance in eight directions (rtrace -ab 0 looking at the sky; 179 lm/W, Radiance's
white efficacy, and Radiance's own RGB-to-luminance weights).

gendaylit takes 2 cm of precipitable water; its azimuths and longitudes are Radiance's
(west positive); the sun vector's x is east, y north, z up, as libimap's default sky.

Run:  python3 -m venv /tmp/rad && /tmp/rad/bin/pip install pyradiance==1.3.1
      /tmp/rad/bin/python scripts/radiance_perez.py > tests/data/radiance_perez.txt
"""
import math
import os
import subprocess
import tempfile

import pyradiance

BIN = os.path.join(os.path.dirname(pyradiance.__file__), "bin")
LIB = os.path.join(os.path.dirname(pyradiance.__file__), "lib")
ENV = dict(os.environ, PATH=BIN + os.pathsep + os.environ.get("PATH", ""), RAYPATH=LIB)

# month, day, hour (local standard time), latitude (N), longitude (W), meridian (W),
# direct normal W/m2, diffuse horizontal W/m2: every clearness bin, low and high suns.
CASES = [
    (12, 15, 12.0, 51.5, 0.0, 0.0, 0.0, 80.0),
    (3, 21, 10.5, 40.0, 105.0, 105.0, 30.0, 220.0),
    (3, 21, 14.0, 40.0, 105.0, 105.0, 120.0, 260.0),
    (5, 10, 9.0, 48.0, -11.0, -15.0, 250.0, 230.0),
    (5, 10, 15.0, 48.0, -11.0, -15.0, 420.0, 200.0),
    (7, 1, 11.0, 35.0, 120.0, 120.0, 560.0, 160.0),
    (9, 12, 16.0, 52.0, -13.0, -15.0, 640.0, 110.0),
    (6, 21, 12.0, 47.0, -8.0, -15.0, 820.0, 95.0),
    (1, 15, 10.0, 55.0, -12.0, -15.0, 700.0, 45.0),
    (6, 21, 12.5, 20.0, 100.0, 105.0, 900.0, 70.0),
]

# Directions (x east, y north, z up) where the sky's luminance is read.
DIRECTIONS = [
    (0.0, 0.0, 1.0),
    (0.0, -0.7, 0.714),
    (0.5, 0.5, 0.707),
    (-0.8, 0.2, 0.566),
    (0.3, -0.85, 0.433),
    (-0.6, -0.6, 0.529),
    (0.85, -0.2, 0.487),
    (0.1, 0.9, 0.424),
]


def run(args, stdin=None):
    return subprocess.run(args, input=stdin, capture_output=True, text=True, env=ENV,
                          check=True).stdout


def luminance(rgb):
    r, g, b = rgb
    return 179.0 * (0.265 * r + 0.670 * g + 0.065 * b)


def main():
    print("# Radiance 6.0a gendaylit Perez skies (scripts/radiance_perez.py)")
    print("# month day hour lat lon_w mer_w dni dhi | sun_x sun_y sun_z | eps delta | a b c d e"
          " | sun_radiance_w_sr_m2 dhi_lx | luminance (cd/m2) in the 8 directions of the script")
    print("# directions: " + " ".join("%g,%g,%g" % d for d in DIRECTIONS))
    with tempfile.TemporaryDirectory() as tmp:
        for (mo, da, hr, lat, lon, mer, dni, dhi) in CASES:
            args = ["gendaylit", str(mo), str(da), "%g" % hr, "-a", "%g" % lat, "-o", "%g" % lon,
                    "-m", "%g" % mer, "-W", "%g" % dni, "%g" % dhi]
            full = run(args)
            eps = delta = None
            sun_rad = 0.0
            lines = full.splitlines()
            for i, line in enumerate(lines):
                if line.startswith("# epsilon"):
                    v = line.split(":")[1].split()
                    eps, delta = float(v[0]), float(v[1])
                if line.startswith("void light solar"):
                    sun_rad = float(lines[i + 3].split()[1])
                if line.startswith("10 "):
                    p = [float(x) for x in line.split()[1:]]
            a_e = p[2:7]
            sun = p[7:10]
            sky = run(args + ["-s"])
            path = os.path.join(tmp, "sky.rad")
            with open(path, "w") as f:
                f.write(sky)
                f.write("skyfunc glow skyglow 0 0 4 1 1 1 0\n"
                        "skyglow source sky 0 0 4 0 0 1 180\n"
                        "skyfunc glow groundglow 0 0 4 1 1 1 0\n"
                        "groundglow source ground 0 0 4 0 0 -1 180\n")
            oct_path = os.path.join(tmp, "sky.oct")
            with open(oct_path, "wb") as f:
                f.write(subprocess.run(["oconv", path], capture_output=True, env=ENV,
                                       check=True).stdout)
            e = run(["rtrace", "-h", "-w", "-I", "-ab", "1", "-ad", "65536", "-aa", "0", "-as",
                     "0", "-lw", "1e-7", oct_path], "0 0 0 0 0 1\n")
            e_dh = luminance([float(x) for x in e.split()[:3]])
            rays = "".join("0 0 0 %g %g %g\n" % d for d in DIRECTIONS)
            lum = run(["rtrace", "-h", "-w", "-ab", "0", oct_path], rays)
            ls = [luminance([float(x) for x in row.split()[:3]]) for row in lum.splitlines()]
            print("%d %d %g %g %g %g %g %g | %.6f %.6f %.6f | %.4f %.4f | %s | %.4e %.2f | %s" % (
                mo, da, hr, lat, lon, mer, dni, dhi, sun[0], sun[1], sun[2], eps, delta,
                " ".join("%.6f" % x for x in a_e), sun_rad, e_dh,
                " ".join("%.3f" % x for x in ls)))


if __name__ == "__main__":
    main()
