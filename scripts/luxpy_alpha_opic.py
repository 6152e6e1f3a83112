#!/usr/bin/env python3
"""Writes tests/data/luxpy_alpha_opic.txt: the α-opic daylight (D65) efficacy ratios of CIE
S 026/E:2018 (α-opic EDI per lx of illuminance: S-cone, M-cone, L-cone, rhodopic,
melanopic) of CIE illuminant A and of the CIE 15:2018 LED illuminant LED-B2 (a
phosphor-converted white LED of 2998 K), computed by luxpy's CIE S 026 implementation (an
independent one; it reproduces the CIE α-opic toolbox), with LED-B2's spectrum at 1 nm.
tests/glare.rs checks libimap's observers against them. Run:
pip install luxpy==1.12.5 numpy==2.1.3 matplotlib; python3 scripts/luxpy_alpha_opic.py > tests/data/luxpy_alpha_opic.txt
"""
import luxpy as lx
from luxpy.toolboxes import photbiochem as pb

print("# luxpy %s, CIE S 026 action spectra (toolbox v1.049): name S M L rhodopic melanopic" % lx.__version__)
for name in ["A", "LED_B2"]:
    spd = lx._CIE_ILLUMINANTS[name]
    # luxpy's order: L (erythropic), M (chloropic), S (cyanopic), rhodopic, melanopic.
    l, m, s, r, mel = pb.spd_to_aopicDER(spd)[0]
    print("der %s %.6f %.6f %.6f %.6f %.6f" % (name, s, m, l, r, mel))
spd = lx._CIE_ILLUMINANTS["LED_B2"]
print("# LED_B2 relative spectral power: nm value")
for nm, v in zip(spd[0], spd[1]):
    print("led_b2 %d %.6g" % (nm, v))
