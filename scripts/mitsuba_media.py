#!/usr/bin/env python3
"""Writes tests/data/mitsuba_media.txt: irradiance on a black receiver that sees a slab
holding a scattering medium, lit by a rectangular Lambertian emitter, rendered by Mitsuba 3
(`scalar_rgb`, `volpath` integrator, an `irradiancemeter` on the receiver), for
tests/media.rs to compare libimap's map with. Both tools get the same geometry (metres), the
same medium and the emitter's radiance L (libimap: exitance πL).

The geometry is scripts/mitsuba_scenes.py's (all z up; emitter 1 × 1 m at z = 1 facing
down, centred at (−0.6, 0); receiver 0.4 × 0.4 m at z = 1 facing down, centred at
(+0.6, 0), black): a 6 × 6 × 0.1 m slab (top face at z = 0) over a white Lambertian ground
(ρ 0.8) at z = −0.12. Inside the slab a homogeneous medium: σt 20 /m, single-scattering
albedo 0.8 (σs 16, σa 4 /m), Henyey–Greenstein g 0.5. Scenes:
- glass: the slab's surface a smooth `dielectric` of index 1.5 (an opal slab);
- haze: the slab's surface `null` (index 1: the medium alone).
The receiver sees what the slab and the ground send up. Each row: scene, irradiance
(W/m², channel R = G = B), its standard error over 16 independent renders.

Run: pip install mitsuba==3.9.1; python3 scripts/mitsuba_media.py > tests/data/mitsuba_media.txt
"""
import math
import os
import sys

import mitsuba as mi

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_scenes import rect  # noqa: E402  (the same rectangles as the surfaces' comparison)

mi.set_variant("scalar_rgb")
L = 10.0  # emitter radiance, W/(m² sr) per channel
RUNS = 16
SPP = 1 << 18


def scene(kind, seed):
    meter = {
        "type": "irradiancemeter",
        "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": SPP, "seed": seed},
    }
    medium = {
        "type": "homogeneous",
        "sigma_t": 20.0,
        "albedo": {"type": "rgb", "value": [0.8, 0.8, 0.8]},
        "phase": {"type": "hg", "g": 0.5},
    }
    surface = {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0} if kind == "glass" else {"type": "null"}
    slab = mi.ScalarTransform4f().translate([0.0, 0.0, -0.05]).scale([3.0, 3.0, 0.05])
    d = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 64},
        "emitter": rect(-0.6, 0.0, 1.0, 1.0, 1.0, True,
                        emitter={"type": "area", "radiance": {"type": "rgb", "value": [L, L, L]}}),
        "receiver": rect(0.6, 0.0, 1.0, 0.4, 0.4, True, sensor=meter),
        "slab": {"type": "cube", "to_world": slab, "bsdf": surface, "interior": medium},
        "ground": rect(0.0, 0.0, -0.12, 6.0, 6.0, False, bsdf={
            "type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}}),
    }
    return mi.load_dict(d)


print("# Mitsuba %s scalar_rgb volpath, %d renders × %d samples; L = %g W/(m² sr)"
      % (mi.__version__, RUNS, SPP, L))
for kind in ("glass", "haze"):
    vals = []
    for r in range(RUNS):
        img = mi.render(scene(kind, r + 1), seed=r + 1)
        vals.append(float(mi.TensorXf(img).array[0]))
    m = sum(vals) / RUNS
    sd = math.sqrt(sum((v - m) ** 2 for v in vals) / (RUNS - 1))
    print("%s %.6f %.6f" % (kind, m, sd / math.sqrt(RUNS)), flush=True)
