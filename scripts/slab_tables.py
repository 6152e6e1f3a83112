#!/usr/bin/env python3
"""Writes tests/data/slab_tables.txt: the total reflection and transmission of a plane slab
of isotropic or Henyey–Greenstein scatterers, index-matched (no Fresnel at either face),
for a collimated beam at normal incidence (van de Hulst's UR1 and UT1, the unscattered
beam included in UT1), for tests/media.rs to compare libimap's photons with.

The numbers come from van de Hulst's adding-doubling method as Scott Prahl's `iadpython`
implements it (pip install iadpython==0.5.3 scipy). The script does not take them on
trust:
- every row is computed with 16 and with 24 quadrature points and must agree to 2e-4
  (iadpython 0.5.3 loses energy at 32 points and above, so neither is used);
- a conservative slab (albedo 1) must give UR1 + UT1 = 1 to 1e-6;
- a slab 1000 optical depths thick must reflect as Chandrasekhar's H-function says for a
  semi-infinite medium, 1 − H(1) √(1 − a), to 2e-4.
Each row: albedo a, optical thickness b, asymmetry g, UR1, UT1.

Run: python3 scripts/slab_tables.py > tests/data/slab_tables.txt
"""
import math
import sys

import iadpython as iad

ROWS = [
    # (b, g): one run of three bands in the test, albedos 0.5, 0.9 and 1.
    (1.0, 0.0),
    (4.0, 0.0),
    (2.0, 0.75),
    (0.5, -0.5),
]
ALBEDOS = (0.5, 0.9, 1.0)


def rt(a, b, g, q):
    s = iad.Sample(a=a, b=b, g=g, n=1.0, n_above=1.0, n_below=1.0, quad_pts=q)
    ur1, ut1, _uru, _utu = s.rt()
    return float(ur1), float(ut1)


def h_at_1(w, n=4000):
    """Chandrasekhar's H(1) for isotropic scattering of albedo w (midpoint grid)."""
    mu = [(i + 0.5) / n for i in range(n)]
    h = [1.0] * n
    for _ in range(2000):
        nxt = [1.0 / (1.0 - 0.5 * w * m * sum(h2 / (m + m2) for m2, h2 in zip(mu, h)) / n)
               for m in mu]
        change = max(abs(x - y) for x, y in zip(nxt, h))
        h = nxt
        if change < 1e-12:
            break
    return 1.0 / (1.0 - 0.5 * w * sum(h2 / (1.0 + m2) for m2, h2 in zip(mu, h)) / n)


def main():
    for w in (0.5, 0.9):
        exact = 1.0 - h_at_1(w, 400) * math.sqrt(1.0 - w)
        r, _ = rt(w, 1000.0, 0.0, 24)
        if abs(r - exact) > 2e-4:
            sys.exit("semi-infinite a %g: adding-doubling %.6f, Chandrasekhar %.6f" % (w, r, exact))
    print("# iadpython %s adding-doubling (24 quadrature points, checked against 16), index 1"
          % iad.__version__)
    print("# a b g UR1 UT1 (normal incidence; UT1 includes the unscattered beam)")
    for b, g in ROWS:
        for a in ALBEDOS:
            r, t = rt(a, b, g, 24)
            r16, t16 = rt(a, b, g, 16)
            if abs(r - r16) > 2e-4 or abs(t - t16) > 2e-4:
                sys.exit("a %g b %g g %g: 24 points %.6f %.6f, 16 points %.6f %.6f"
                         % (a, b, g, r, t, r16, t16))
            if a == 1.0 and abs(r + t - 1.0) > 1e-6:
                sys.exit("a 1 b %g g %g: R + T = %.8f" % (b, g, r + t))
            print("%g %g %g %.6f %.6f" % (a, b, g, r, t))


if __name__ == "__main__":
    main()
