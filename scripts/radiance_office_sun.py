#!/usr/bin/env python3
"""Radiance's direct sun in the glazed side-lit office, for tests/daylight.rs.

The office of scripts/radiance_office_dc.py (4 m wide along x = east, 6 m deep along
y = north, 3 m high, a window x 0.5-3.5 m, z 0.9-2.4 m in its south wall), the window
glazed with Radiance's `glass` of index 1.52 and transmissivity 1 (a clear pane without
absorption; Radiance sums its inter-reflections per polarisation). For every hour of
tests/data/pvgis_45n_8e_21st.wea with the sun up and direct light, the sun is placed where
pvlib's NREL SPA puts it (apparent position: refraction for 1013.25 hPa and 10 C, the
library's standard atmosphere) at the middle of the hour in local standard time
(UTC+1, the file's time_zone -15), in 2001 (the year the library gives a .wea row), at
the file's latitude, longitude and elevation. The sun is a 0.533 deg disc of radiance
1 / solid angle, so a plane facing it gets 1 W/m2; rtrace -ab 0 -I (direct light only)
gives each of the 24 sensors (z = 0.8 m, facing up) its direct irradiance per unit normal
irradiance, T cos(theta), through the glass.

Output (tests/data/radiance_office_sun.txt): one line per sunlit hour: month day hour,
the sun's apparent zenith and azimuth (deg, from north toward east), then the 24 sensors'
values (sensor order x fastest, as in the office test).

Run:  python3 -m venv /tmp/rad && /tmp/rad/bin/pip install pyradiance==1.3.1 pvlib==0.16.1
      /tmp/rad/bin/python scripts/radiance_office_sun.py
"""
import math
import os
import subprocess
import tempfile

import pandas as pd
import pvlib
import radiance_office_dc

ENV, DATA = radiance_office_dc.ENV, radiance_office_dc.DATA

# The office and its sensors, as the coefficients' script has them; the window glazed.
ROOM = radiance_office_dc.ROOM + """void glass pane_m 0 0 4 1 1 1 1.52
pane_m polygon window 0 0 12  0.5 0 0.9  3.5 0 0.9  3.5 0 2.4  0.5 0 2.4
"""
SENSORS = radiance_office_dc.SENSORS
DISC_DEG = 0.533


def read_wea(path):
    head, rows = {}, []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w:
                continue
            if w[0][0].isalpha():
                head[w[0]] = w[1:]
            else:
                rows.append((int(w[0]), int(w[1]), float(w[2]), float(w[3]), float(w[4])))
    return head, rows


def main():
    head, rows = read_wea(os.path.join(DATA, "pvgis_45n_8e_21st.wea"))
    lat = float(head["latitude"][0])
    lon = -float(head["longitude"][0])  # Radiance's longitude is west-positive
    utc = -float(head["time_zone"][0]) / 15.0
    elevation = float(head["site_elevation"][0])
    omega = 2 * math.pi * (1 - math.cos(math.radians(DISC_DEG / 2)))
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        room = os.path.join(tmp, "room.rad")
        with open(room, "w") as f:
            f.write(ROOM)
        rays = "".join("%g %g %g 0 0 1\n" % s for s in SENSORS)
        for month, day, hour, dn, _dh in rows:
            if dn <= 0:
                continue
            minutes = round(hour * 60)
            t = pd.Timestamp(2001, month, day, minutes // 60, minutes % 60,
                             tz="Etc/GMT%+d" % -utc if utc else "UTC")
            sp = pvlib.solarposition.get_solarposition(
                pd.DatetimeIndex([t]), lat, lon, altitude=elevation, pressure=101325,
                temperature=10, method="nrel_numpy")
            zen = float(sp["apparent_zenith"].iloc[0])
            az = float(sp["azimuth"].iloc[0])
            if zen >= 90:
                continue
            z, a = math.radians(zen), math.radians(az)
            d = (math.sin(z) * math.sin(a), math.sin(z) * math.cos(a), math.cos(z))
            sun = os.path.join(tmp, "sun.rad")
            with open(sun, "w") as f:
                f.write("void light solar 0 0 3 %.9g %.9g %.9g\n" % ((1 / omega,) * 3))
                f.write("solar source sun 0 0 4 %.9f %.9f %.9f %g\n" % (d + (DISC_DEG,)))
            oct_ = os.path.join(tmp, "s.oct")
            with open(oct_, "wb") as f:
                subprocess.run(["oconv", sun, room], stdout=f, env=ENV, check=True)
            r = subprocess.run(["rtrace", "-h", "-I+", "-ab", "0", "-dj", "0", "-ds", "0",
                                "-ov", oct_], input=rays, capture_output=True, text=True,
                               env=ENV, check=True).stdout
            values = [float(line.split()[1]) for line in r.splitlines() if line.strip()]
            assert len(values) == len(SENSORS), r
            out.append("%d %d %g %.6f %.6f " % (month, day, hour, zen, az)
                       + " ".join("%.6g" % v for v in values))
    with open(os.path.join(DATA, "radiance_office_sun.txt"), "w") as f:
        f.write("# scripts/radiance_office_sun.py: Radiance 6.0a rtrace -ab 0, pvlib %s SPA\n"
                % pvlib.__version__)
        f.write("# month day hour apparent_zenith azimuth, then T cos(theta) at the 24 sensors\n")
        f.write("\n".join(out) + "\n")
    print("%d sunlit hours" % len(out))


if __name__ == "__main__":
    main()
