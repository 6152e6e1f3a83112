#!/usr/bin/env python3
"""Writes tests/data/mitsuba_haze.txt: the picture of a closed grey room filled with haze
and lit by one isotropic point light, rendered by Mitsuba 3 (`scalar_rgb`, `volpath`), for
tests/haze.rs to compare libimap's renderers with (the scene's medium, light samples at
scattering points in it, eye paths attenuated and scattered by it).

The scene (metres, z up), the same in tests/haze.rs:
- the room [0, 2]³, its six walls Lambertian ρ 0.5 facing in;
- haze filling it: σs 0.8 /m, σa 0.2 /m (σt 1, albedo 0.8), Henyey–Greenstein g 0.5;
- a point light of 1 W per channel (intensity 1/(4π) W/sr) at (1, 1, 1.6);
- a pinhole camera at (1, 0.1, 1) looking along +y, up +z, 60° square field of view,
  8 × 8 pixels (box filter).
The scene is mirror-symmetric about x = 1, so the image does not depend on which way a
tool's image x runs. Each row: pixel index (row-major from the top), radiance (W/(m² sr),
channel R = G = B), its standard error over 16 independent renders.

Run: pip install mitsuba==3.9.1; python3 scripts/mitsuba_haze.py > tests/data/mitsuba_haze.txt
"""
import math

import mitsuba as mi

mi.set_variant("scalar_rgb")
RUNS = 16
SPP = 1 << 14
W = 8


def scene(seed):
    haze = {
        "type": "homogeneous",
        "sigma_t": 1.0,
        "albedo": {"type": "rgb", "value": [0.8, 0.8, 0.8]},
        "phase": {"type": "hg", "g": 0.5},
    }
    grey = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}
    d = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 64},
        "haze": haze,
        "sensor": {
            "type": "perspective",
            "fov": 60.0,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[1.0, 0.1, 1.0], target=[1.0, 1.1, 1.0], up=[0.0, 0.0, 1.0]),
            "film": {"type": "hdrfilm", "width": W, "height": W,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": SPP, "seed": seed},
            "medium": {"type": "ref", "id": "haze"},
        },
        "light": {
            "type": "point",
            "position": [1.0, 1.0, 1.6],
            "intensity": {"type": "rgb", "value": [1.0 / (4.0 * math.pi)] * 3},
            "medium": {"type": "ref", "id": "haze"},
        },
        "room": {
            "type": "cube",
            "to_world": mi.ScalarTransform4f().translate([1.0, 1.0, 1.0]).scale([1.0, 1.0, 1.0]),
            "flip_normals": True,
            "bsdf": grey,
            # With its normals turned inward, the room's inside is the cube's exterior
            # side: a ray reflected by a wall takes the medium on the side it leaves to.
            "exterior": {"type": "ref", "id": "haze"},
        },
    }
    return mi.load_dict(d)


print("# Mitsuba %s scalar_rgb volpath, %d renders × %d samples per pixel, %d × %d pixels"
      % (mi.__version__, RUNS, SPP, W, W))
vals = []
for r in range(RUNS):
    flat = mi.TensorXf(mi.render(scene(r + 1), seed=r + 1)).array  # rows, columns, RGB
    vals.append([float(flat[3 * p]) for p in range(W * W)])
for p in range(W * W):
    v = [run[p] for run in vals]
    m = sum(v) / RUNS
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (RUNS - 1))
    print("%d %.6e %.6e" % (p, m, sd / math.sqrt(RUNS)), flush=True)
