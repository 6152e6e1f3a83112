#!/usr/bin/env python3
"""Writes tests/data/mitsuba_bsdf.txt: directional albedos of Mitsuba 3's GGX
`roughconductor` and `roughdielectric` (visible-normal sampling, importance transport) at
normal incidence, where Mitsuba's separable Smith G1(wo)·G1(wi) and our height-correlated
G2 are the same function. tests/mitsuba.rs compares libimap's single-scattering models with
them. Run: pip install mitsuba==3.9.1; python3 scripts/mitsuba_bsdf.py > tests/data/mitsuba_bsdf.txt
"""
import math
import random

import mitsuba as mi

mi.set_variant("scalar_rgb")
N = 40000
random.seed(20261127)
print("# Mitsuba %s, scalar_rgb, %d samples per row: model alpha front albedo stderr" % (mi.__version__, N))
print("# conductor: eta = 1.2, k = 7.0; dielectric: int_ior = 1.5, ext_ior = 1.0")


def albedo(bsdf, front):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(0.0, 0.0, 1.0 if front else -1.0)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    s = s2 = 0.0
    for _ in range(N):
        _, w = bsdf.sample(ctx, si, random.random(), mi.Point2f(random.random(), random.random()))
        x = float(w[0])
        s += x
        s2 += x * x
    m = s / N
    return m, math.sqrt(max(s2 / N - m * m, 0.0) / N)


for a in [0.1, 0.3, 0.6, 1.0]:
    c = mi.load_dict({"type": "roughconductor", "distribution": "ggx", "alpha": a,
                      "eta": 1.2, "k": 7.0, "sample_visible": True})
    m, e = albedo(c, True)
    print("conductor %.2f 1 %.6f %.6f" % (a, m, e))
    d = mi.load_dict({"type": "roughdielectric", "distribution": "ggx", "alpha": a,
                      "int_ior": 1.5, "ext_ior": 1.0, "sample_visible": True})
    for front in (True, False):
        m, e = albedo(d, front)
        print("dielectric %.2f %d %.6f %.6f" % (a, int(front), m, e))
