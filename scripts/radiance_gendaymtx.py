#!/usr/bin/env python3
"""Radiance's sky vectors (gendaymtx), for the tests of libimap's sky patches.

For hours of scripts/radiance_perez.py's cases, Radiance 6.0a's gendaymtx (the
`pyradiance` wheel on PyPI bundles it) writes the Perez sky's radiance per patch of the
Tregenza sky (-m 1) and of Reinhart's MF:2 (-m 2), sky only (-s), white (-c 1 1 1), no
ground (-g 0 0 0). gendaylit, which places the sun by the same solar routine, gives the
sun's direction (x east, y north, z up). Each case is a line

    month day hour lat lon_w mer_w dni dhi mf | sun_x sun_y sun_z | L_0 L_1 ... (cd/m2)

with the patches' luminance as gendaymtx prints them (3 significant digits, times 179
lm/W), patch 0 the ground.

Run:  python3 -m venv /tmp/rad && /tmp/rad/bin/pip install pyradiance==1.3.1
      /tmp/rad/bin/python scripts/radiance_gendaymtx.py > tests/data/radiance_gendaymtx.txt
"""
import os
import subprocess
import tempfile

import pyradiance

BIN = os.path.join(os.path.dirname(pyradiance.__file__), "bin")
LIB = os.path.join(os.path.dirname(pyradiance.__file__), "lib")
ENV = dict(os.environ, PATH=BIN + os.pathsep + os.environ.get("PATH", ""), RAYPATH=LIB)

# month, day, hour, latitude (N), longitude (W), meridian (W), direct normal and diffuse
# horizontal W/m2, Reinhart MF.
CASES = [
    (12, 15, 12.0, 51.5, 0.0, 0.0, 0.0, 80.0, 1),
    (3, 21, 14.0, 40.0, 105.0, 105.0, 120.0, 260.0, 1),
    (5, 10, 15.0, 48.0, -11.0, -15.0, 420.0, 200.0, 1),
    (9, 12, 16.0, 52.0, -13.0, -15.0, 640.0, 110.0, 1),
    (6, 21, 12.0, 47.0, -8.0, -15.0, 820.0, 95.0, 1),
    (6, 21, 12.0, 47.0, -8.0, -15.0, 820.0, 95.0, 2),
]


def run(args, stdin=None):
    return subprocess.run(args, input=stdin, capture_output=True, text=True, env=ENV,
                          check=True).stdout


def main():
    print("# Radiance 6.0a gendaymtx sky vectors (scripts/radiance_gendaymtx.py)")
    print("# month day hour lat lon_w mer_w dni dhi mf | sun_x sun_y sun_z | patch luminance cd/m2")
    with tempfile.TemporaryDirectory() as tmp:
        for (mo, da, hr, lat, lon, mer, dni, dhi, mf) in CASES:
            wea = os.path.join(tmp, "t.wea")
            with open(wea, "w") as f:
                f.write("place t\nlatitude %g\nlongitude %g\ntime_zone %g\nsite_elevation 0\n"
                        "weather_data_file_units 1\n%d %d %g %g %g\n"
                        % (lat, lon, mer, mo, da, hr, dni, dhi))
            out = run(["gendaymtx", "-m", str(mf), "-s", "-c", "1", "1", "1", "-g", "0", "0", "0",
                       wea])
            body = out.split("\n\n", 1)[1]
            values = [float(line.split()[1]) * 179.0 for line in body.splitlines() if line.strip()]
            lit = run(["gendaylit", str(mo), str(da), "%g" % hr, "-a", "%g" % lat, "-o", "%g" % lon,
                       "-m", "%g" % mer, "-W", "%g" % dni, "%g" % dhi])
            sun = [line for line in lit.splitlines() if line.startswith("10 ")][0].split()[8:11]
            print("%d %d %g %g %g %g %g %g %d | %s | %s" % (
                mo, da, hr, lat, lon, mer, dni, dhi, mf, " ".join(sun),
                " ".join("%.4g" % v for v in values)))


if __name__ == "__main__":
    main()
