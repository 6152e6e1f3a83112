#!/usr/bin/env python3
"""Radiance's daylight coefficients of a side-lit office, for tests/daylight.rs.

The office: 4 m wide (x, east), 6 m deep (y, north), 3 m high, its south wall (y = 0) open
in a window x 0.5-3.5 m, z 0.9-2.4 m (no glazing). Floor rho 0.2, walls 0.5, ceiling 0.7,
all Lambertian and grey. 24 sensors at z = 0.8 m facing up, x 0.5-3.5 and y 0.5-5.5 in
1 m steps. Radiance 6.0a's rfluxmtx (the `pyradiance` wheel on PyPI bundles it) computes
each sensor's coefficient for the ground hemisphere (h=u) and the 145 Tregenza patches
(h=r1, north +Y): irradiance per unit radiance, i.e. lx per cd/m2, by pure path tracing
(-ab 6 -ad 1 -lw 1e-7, 200 000 paths per sensor). It runs twice, the second time with the
sensors in reverse order (so every sensor gets other random numbers): the two runs'
difference measures Radiance's own noise.

It also writes the 21st of every month of the PVGIS typical year at 45 N 8 E that pvlib's
source distribution ships as test data (tests/data/tmy_45.000_8.000_2005_2023.epw of
pvlib 0.16.1, ECMWF ERA based) as a Radiance .wea file: the test's sky vectors.

Run:  python3 -m venv /tmp/rad && /tmp/rad/bin/pip install pyradiance==1.3.1
      /tmp/rad/bin/pip download pvlib==0.16.1 --no-deps --no-binary :all: -d /tmp/pvlib
      /tmp/rad/bin/python scripts/radiance_office_dc.py /tmp/pvlib/pvlib-0.16.1.tar.gz
"""
import os
import subprocess
import sys
import tarfile
import tempfile

import pyradiance

BIN = os.path.join(os.path.dirname(pyradiance.__file__), "bin")
LIB = os.path.join(os.path.dirname(pyradiance.__file__), "lib")
ENV = dict(os.environ, PATH=BIN + os.pathsep + os.environ.get("PATH", ""), RAYPATH=LIB)
HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "tests", "data")
PATHS = 200000

ROOM = """void plastic floor_m 0 0 5 .2 .2 .2 0 0
void plastic wall_m 0 0 5 .5 .5 .5 0 0
void plastic ceil_m 0 0 5 .7 .7 .7 0 0
floor_m polygon floor 0 0 12  0 0 0  0 6 0  4 6 0  4 0 0
ceil_m polygon ceiling 0 0 12  0 0 3  4 0 3  4 6 3  0 6 3
wall_m polygon west 0 0 12  0 0 0  0 0 3  0 6 3  0 6 0
wall_m polygon east 0 0 12  4 0 0  4 6 0  4 6 3  4 0 3
wall_m polygon north 0 0 12  0 6 0  0 6 3  4 6 3  4 6 0
wall_m polygon south_low 0 0 12  0 0 0  4 0 0  4 0 0.9  0 0 0.9
wall_m polygon south_high 0 0 12  0 0 2.4  4 0 2.4  4 0 3  0 0 3
wall_m polygon south_w 0 0 12  0 0 0.9  0.5 0 0.9  0.5 0 2.4  0 0 2.4
wall_m polygon south_e 0 0 12  3.5 0 0.9  4 0 0.9  4 0 2.4  3.5 0 2.4
"""

SKY = """#@rfluxmtx h=u u=+Y
void glow groundglow 0 0 4 1 1 1 0
groundglow source ground 0 0 4 0 0 -1 180
#@rfluxmtx h=r1 u=+Y
void glow skyglow 0 0 4 1 1 1 0
skyglow source skydome 0 0 4 0 0 1 180
"""

SENSORS = [(x, y, 0.8) for y in (0.5, 1.5, 2.5, 3.5, 4.5, 5.5) for x in (0.5, 1.5, 2.5, 3.5)]


def coefficients(tmp, order):
    rays = os.path.join(tmp, "rays.txt")
    with open(rays, "w") as f:
        for i in order:
            x, y, z = SENSORS[i]
            f.write(("%g %g %g 0 0 1\n" % (x, y, z)) * PATHS)
    with open(rays) as f:
        out = subprocess.run(["rfluxmtx", "-I+", "-ab", "6", "-ad", "1", "-lw", "1e-7", "-c",
                              str(PATHS), "-h", "-", os.path.join(tmp, "sky.rad"),
                              os.path.join(tmp, "room.rad")], stdin=f, capture_output=True,
                             text=True, env=ENV, check=True).stdout
    rows = [[float(v) for v in line.split()] for line in out.splitlines() if line.strip()]
    result = [None] * len(SENSORS)
    for i, row in zip(order, rows):
        result[i] = row[1::3]  # grey: the green channel
    return result


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in (("room.rad", ROOM), ("sky.rad", SKY)):
            with open(os.path.join(tmp, name), "w") as f:
                f.write(text)
        a = coefficients(tmp, list(range(len(SENSORS))))
        b = coefficients(tmp, list(reversed(range(len(SENSORS)))))
    with open(os.path.join(DATA, "radiance_office_dc.txt"), "w") as f:
        f.write("# Radiance 6.0a rfluxmtx daylight coefficients of the side-lit office "
                "(scripts/radiance_office_dc.py)\n")
        f.write("# x y z | run A: ground, patches 1-145 (lx per cd/m2) | run B (sensors reversed)\n")
        for s, ca, cb in zip(SENSORS, a, b):
            f.write("%g %g %g | %s | %s\n" % (s[0], s[1], s[2], " ".join("%.6g" % v for v in ca),
                                              " ".join("%.6g" % v for v in cb)))
    with tarfile.open(sys.argv[1]) as t:
        epw = t.extractfile("pvlib-0.16.1/tests/data/tmy_45.000_8.000_2005_2023.epw").read()
    lines = epw.decode("latin-1").splitlines()
    loc = lines[0].split(",")
    lat, lon, tz, elev = float(loc[6]), float(loc[7]), float(loc[8]), float(loc[9])
    with open(os.path.join(DATA, "pvgis_45n_8e_21st.wea"), "w") as f:
        f.write("place PVGIS_TMY_45N_8E_(pvlib_0.16.1_test_data)\nlatitude %g\nlongitude %g\n"
                "time_zone %g\nsite_elevation %g\nweather_data_file_units 1\n"
                % (lat, -lon, -15 * tz, elev))
        for line in lines[8:]:
            v = line.split(",")
            if len(v) < 16 or int(v[2]) != 21:
                continue
            f.write("%d %d %.1f %.1f %.1f\n" % (int(v[1]), int(v[2]), int(v[3]) - 0.5,
                                                max(0.0, float(v[14])), max(0.0, float(v[15]))))


if __name__ == "__main__":
    main()
