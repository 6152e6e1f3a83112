#!/usr/bin/env python3
"""evalglare's DGP of fisheye pictures of a sunlit office, for tests/glare_picture.rs.

The office of scripts/radiance_office_dc.py (4 m wide along x = east, 6 m deep along
y = north, 3 m high, a window x 0.5-3.5 m, z 0.9-2.4 m in its south wall, unglazed) under
gendaylit's Perez sky for the sun 25 deg high in the south and 20 deg west of it, with
600 W/m2 direct normal and 120 W/m2 diffuse horizontal irradiance. Radiance 6.0a's rpict
(the `pyradiance` wheel bundles it) renders 240 x 240 angular fisheyes (-vta -vh 180
-vv 180) from two eyes at 1.2 m:
- "window": at (2, 4.5) looking south at the window (the sunlit floor and the bright sky
  in view, the sun above the window's head);
- "sun": at (1.2, 1.2) looking south-west (the sun's disc through the window).
evalglare 3.06 (the same wheel), with its defaults (threshold 2000 cd/m2, search radius
0.2 rad, peak extraction at 50 000 cd/m2, no low-light correction), rates each picture
(-d: the detailed output). The pictures are committed (tests/data/evalglare_*.hdr) so the
test rates the very same pixels.

Output (tests/data/evalglare_office.txt): per picture: name, eye, view, DGP, Ev (lx) and
the number of glare sources, then each source's solid angle (sr) and luminance (cd/m2).

Run:  python3 -m venv /tmp/rad && /tmp/rad/bin/pip install pyradiance==1.3.1
      /tmp/rad/bin/python scripts/evalglare_office.py
"""
import os
import shutil
import subprocess
import tempfile

import radiance_office_dc

ENV, DATA, ROOM = radiance_office_dc.ENV, radiance_office_dc.DATA, radiance_office_dc.ROOM

VIEWS = [
    ("window", (2.0, 4.5, 1.2), (0.0, -1.0, 0.0)),
    ("sun", (1.2, 1.2, 1.2), (-0.35, -1.0, 0.0)),
]
SIZE = 240


def run(args, **kw):
    return subprocess.run(args, env=ENV, check=True, capture_output=True, **kw)


def main():
    out = ["# evalglare 3.06 on rpict (Radiance 6.0a) fisheyes of the sunlit office "
           "(scripts/evalglare_office.py)",
           "# name | eye | view | dgp ev_lx sources | per source: omega_sr luminance_cd_m2"]
    with tempfile.TemporaryDirectory() as tmp:
        sky = run(["gendaylit", "-ang", "25", "20", "-W", "600", "120"], text=True).stdout
        sky += """skyfunc glow sky_glow 0 0 4 1 1 1 0
sky_glow source sky 0 0 4 0 0 1 180
skyfunc glow ground_glow 0 0 4 1 1 1 0
ground_glow source ground 0 0 4 0 0 -1 180
"""
        with open(os.path.join(tmp, "scene.rad"), "w") as f:
            f.write(sky + ROOM)
        with open(os.path.join(tmp, "scene.oct"), "wb") as f:
            f.write(run(["oconv", os.path.join(tmp, "scene.rad")]).stdout)
        for name, eye, view in VIEWS:
            pic = os.path.join(tmp, name + ".hdr")
            with open(pic, "wb") as f:
                f.write(run(["rpict", "-vta", "-vh", "180", "-vv", "180",
                             "-vp", *map(str, eye), "-vd", *map(str, view),
                             "-vu", "0", "0", "1", "-x", str(SIZE), "-y", str(SIZE),
                             "-ab", "2", "-ad", "256", "-as", "64", "-aa", "0.15",
                             "-ar", "64", "-ps", "1", "-pj", "0", "-dj", "0",
                             os.path.join(tmp, "scene.oct")]).stdout)
            text = run(["evalglare", "-d", pic], text=True).stdout
            if os.environ.get("SHOW"):
                print(text)
            dgp, ev, sources = None, None, []
            for line in text.splitlines():
                if line.startswith("dgp,"):
                    dgp, _avlum, ev = (float(v) for v in line.split(":")[1].split()[:3])
                elif line[:1].isdigit() and len(line.split()) > 8:
                    w = line.split()
                    if w[1] == "No":
                        continue  # the header: No pixels x-pos y-pos L_s Omega_s ...
                    sources.append((float(w[5]), float(w[4])))
            if dgp is None:
                raise SystemExit("evalglare printed no dgp line:\n" + text)
            out.append("%s | %g %g %g | %g %g %g | %.6f %.3f %d | %s" % (
                name, *eye, *view, dgp, ev, len(sources),
                " ".join("%.6g %.6g" % s for s in sources)))
            shutil.copy(pic, os.path.join(DATA, "evalglare_%s.hdr" % name))
    with open(os.path.join(DATA, "evalglare_office.txt"), "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
