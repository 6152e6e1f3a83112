#!/usr/bin/env python3
"""Writes tests/data/mitsuba_scenes.txt: irradiance on a black receiver that sees a rough
surface lit by a rectangular Lambertian emitter, rendered by Mitsuba 3 (`scalar_rgb`,
`path` integrator, an `irradiancemeter` on the receiver), for tests/surfaces.rs to compare
libimap's map with. Both tools get the same geometry (metres), the same GGX roughness and
index, and the emitter's radiance L (libimap: exitance πL).

Scenes (a Lambertian floor of ρ 0.5 as the control; all z up; emitter 1 × 1 m at z = 1 facing down, centred at (−0.6, 0); receiver
0.4 × 0.4 m at z = 1 facing down, centred at (+0.6, 0), black; floor 6 × 6 m at z = 0):
- conductor: the floor a `roughconductor` (GGX α 0.15, eta 1.2, k 7.0);
- dielectric: the floor a 6 × 6 × 0.1 m slab of `roughdielectric` (GGX α 0.15, n 1.5)
  (its top face at z = 0) over a white Lambertian ground (ρ 0.8) at z = −0.12.
The receiver sees only light the floor sends up (the emitter faces down, as does the
receiver). Each row: scene, irradiance (W/m², channel R = G = B), its standard error over
16 independent renders.

Run: pip install mitsuba==3.9.1; python3 scripts/mitsuba_scenes.py > tests/data/mitsuba_scenes.txt
"""
import math

import mitsuba as mi

mi.set_variant("scalar_rgb")
L = 10.0  # emitter radiance, W/(m² sr) per channel
RUNS = 16
SPP = 1 << 20


def rect(cx, cy, z, sx, sy, down, bsdf=None, emitter=None, sensor=None):
    # Mitsuba's rectangle spans [-1, 1]² in xy with normal +z.
    t = mi.ScalarTransform4f().translate([cx, cy, z]).scale([sx / 2, sy / 2, 1.0])
    if down:
        t = mi.ScalarTransform4f().translate([cx, cy, z]).rotate([1, 0, 0], 180).scale([sx / 2, sy / 2, 1.0])
    d = {"type": "rectangle", "to_world": t}
    d["bsdf"] = bsdf or {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}
    if emitter:
        d["emitter"] = emitter
    if sensor:
        d["sensor"] = sensor
    return d


def scene(kind, seed):
    meter = {
        "type": "irradiancemeter",
        "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": SPP, "seed": seed},
    }
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 12},
        "emitter": rect(-0.6, 0.0, 1.0, 1.0, 1.0, True,
                        emitter={"type": "area", "radiance": {"type": "rgb", "value": [L, L, L]}}),
        "receiver": rect(0.6, 0.0, 1.0, 0.4, 0.4, True, sensor=meter),
    }
    if kind == "lambert":
        d["floor"] = rect(0.0, 0.0, 0.0, 6.0, 6.0, False, bsdf={
            "type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}})
    elif kind == "conductor":
        d["floor"] = rect(0.0, 0.0, 0.0, 6.0, 6.0, False, bsdf={
            "type": "roughconductor", "distribution": "ggx", "alpha": 0.15,
            "eta": 1.2, "k": 7.0, "sample_visible": True})
    else:
        slab = mi.ScalarTransform4f().translate([0.0, 0.0, -0.05]).scale([3.0, 3.0, 0.05])
        d["slab"] = {"type": "cube", "to_world": slab, "bsdf": {
            "type": "roughdielectric", "distribution": "ggx", "alpha": 0.15,
            "int_ior": 1.5, "ext_ior": 1.0, "sample_visible": True}}
        d["ground"] = rect(0.0, 0.0, -0.12, 6.0, 6.0, False, bsdf={
            "type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}})
    return mi.load_dict(d)


if __name__ == "__main__":
    print("# Mitsuba %s scalar_rgb path tracing, %d renders × %d samples; L = %g W/(m² sr)"
          % (mi.__version__, RUNS, SPP, L))
    for kind in ("lambert", "conductor", "dielectric"):
        vals = []
        for r in range(RUNS):
            img = mi.render(scene(kind, r + 1), seed=r + 1)
            vals.append(float(img.array[0]) if hasattr(img, "array") else float(mi.TensorXf(img).array[0]))
        m = sum(vals) / RUNS
        sd = math.sqrt(sum((v - m) ** 2 for v in vals) / (RUNS - 1))
        print("%s %.6f %.6f" % (kind, m, sd / math.sqrt(RUNS)), flush=True)
