#!/usr/bin/env python3
"""How far a vertex's value (the hat-function average of irradiance over the triangles
around it, what libimap's maps hold) lies from the irradiance at the vertex's point (what a
point sensor of another renderer reads), for the direct light of the grey room of the
benchmarks (the unit cube's six walls at 40 x 40 cells, a 0.2 m square emitter facing down
at height H, exact by Lambert's polygon formula).

The difference is relative to the vertex's whole irradiance: its direct hat average plus
an indirect part taken as uniform, Phi / 6 (a closed room of rho = 0.5: the mean indirect
irradiance equals the mean direct one). Printed per face, and the mean of
(difference / sigma)^2 over the vertices for a per-vertex relative error sigma: what a
point-sampled reference adds to a per-vertex chi^2 that should be 1.

    pip install numpy; scripts/point_vs_hat.py 0.999     (the peers' room of issue 37)
    scripts/point_vs_hat.py 0.98                          (examples/accuracy_bench's room)
"""
import sys

import numpy as np

H = float(sys.argv[1]) if len(sys.argv) > 1 else 0.98
N, M, L = 40, 8, 1.0
POLY = np.array([[0.4, 0.4, H], [0.6, 0.4, H], [0.6, 0.6, H], [0.4, 0.6, H]])


def polygon(x, nrm):
    """Irradiance at points x (k x 3, normal nrm) from the emitter (radiance L)."""
    s = np.zeros(len(x))
    for i in range(4):
        a, b = POLY[i] - x, POLY[(i + 1) % 4] - x
        c = np.cross(a, b)
        cos = (a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        s += np.arccos(np.clip(cos, -1, 1)) * (c @ nrm) / np.maximum(np.linalg.norm(c, axis=1), 1e-300)
    e = L / 2 * np.abs(s)
    e[x[:, 2] >= H] = 0.0  # the emitter faces down
    return e


# Barycentric sample points: the centroids of an M x M subdivision of a triangle.
bs = []
for i in range(M):
    for j in range(M - i):
        bs.append(((i + 1 / 3) / M, (j + 1 / 3) / M))
        if i + j + 1 < M:
            bs.append(((i + 2 / 3) / M, (j + 2 / 3) / M))
bs = np.array(bs)
B = (1 - bs[:, 0] - bs[:, 1], bs[:, 0], bs[:, 1])

X, Y, Z = np.eye(3)
O = np.zeros(3)
FACES = [("floor", O, X, Y), ("ceiling", Z, Y, X), ("y = 0", O, Z, X), ("y = 1", Y, X, Z),
         ("x = 0", O, Y, Z), ("x = 1", X, Z, Y)]
E_IND = np.pi * 0.04 * L / 6
every = []
for name, o, u, v in FACES:
    nrm = np.cross(u, v)
    g = np.linspace(0, 1, N + 1)
    s, t = np.meshgrid(g, g)
    point = polygon((o + s[..., None] * u + t[..., None] * v).reshape(-1, 3), nrm).reshape(N + 1, N + 1)
    num, den = np.zeros((N + 1, N + 1)), np.zeros((N + 1, N + 1))
    for j in range(N):
        for i in range(N):
            # The mesh's two triangles of a cell (as the benchmark room builds them).
            for tri in ([(i, j), (i + 1, j), (i + 1, j + 1)], [(i, j), (i + 1, j + 1), (i, j + 1)]):
                p = [o + (a / N) * u + (b / N) * v for a, b in tri]
                x = B[0][:, None] * p[0] + B[1][:, None] * p[1] + B[2][:, None] * p[2]
                e = polygon(x, nrm)
                for (a, b), w in zip(tri, B):
                    num[b, a] += (e * w).mean()
                    den[b, a] += 1 / 3
    hat = num / den
    rel = ((point - hat) / (hat + E_IND)).ravel()
    every.append(rel)
    print(f"{name:8} |point - hat| / E: mean {np.abs(rel).mean() * 100:.3f} %, "
          f"rms {np.sqrt((rel ** 2).mean()) * 100:.3f} %, max {np.abs(rel).max() * 100:.2f} %")
r = np.concatenate(every)
for sigma in (0.005, 0.01, 0.015):
    print(f"per-vertex sigma {sigma * 100:.1f} %: mean (difference / sigma)^2 = {((r / sigma) ** 2).mean():.3f}")
