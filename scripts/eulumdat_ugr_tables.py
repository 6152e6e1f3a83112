#!/usr/bin/env python3
"""Writes tests/data/ugr_panel.ldt (a synthetic 600 × 600 mm recessed panel: quadrant
symmetry, I = 1000 cos^1.5 γ (1 − 0.25 sin² C sin² γ) cd/klm below the ceiling, 4000 lm
of lamps at 80 %) and tests/data/eulumdat_ugr.txt: the CIE 190:2010 UGR tables of it and of
c_examples/data/wallwasher.ldt by eulumdat-ugr (an independent implementation of the
tabular method, "compatible with DIALux and Relux catalogue output"), unrounded.
tests/photometry.rs compares libimap's tables with them. Run:
pip install eulumdat-ugr==1.0.2 numpy==2.1.3 scipy; python3 scripts/eulumdat_ugr_tables.py
"""
import math
import os

import eulumdat_ugr
from eulumdat_ugr import UgrCalculator
from pyldt import LdtReader

ROOT = os.path.join(os.path.dirname(__file__), "..")
PANEL = os.path.join(ROOT, "tests", "data", "ugr_panel.ldt")


def panel_ldt():
    c = [15.0 * k for k in range(24)]
    g = [5.0 * k for k in range(37)]
    stored = [a for a in c if a <= 90.0]

    def cd(cc, gg):
        if gg > 90.0:
            return 0.0
        s = math.sin(math.radians(gg))
        v = 1000.0 * max(math.cos(math.radians(gg)), 0.0) ** 1.5
        return v * (1.0 - 0.25 * math.sin(math.radians(cc)) ** 2 * s * s)

    lines = ["libimap tests (synthetic photometry)", "1", "4", "24", "15", "37", "5",
             "UGR panel", "Recessed panel 600", "P-600", "ugr_panel.ldt", "2026-12-02 libimap",
             "620", "620", "80", "600", "600", "0", "0", "0", "0", "100", "80", "1", "0",
             "1", "1", "LED", "4000", "4000K", "80", "32"]
    lines += ["0.5"] * 10
    lines += ["%g" % a for a in c]
    lines += ["%g" % a for a in g]
    for a in stored:
        lines += ["%.4f" % cd(a, b) for b in g]
    with open(PANEL, "w") as f:
        f.write("\r\n".join(lines) + "\r\n")


panel_ldt()
print("# eulumdat-ugr %s (CIE 117:1995 / CIE 190:2010 tabular method, SHR 0.25, H = 2 m):" % eulumdat_ugr.__version__
      if hasattr(eulumdat_ugr, "__version__") else "# eulumdat-ugr 1.0.2 (CIE 117:1995 / CIE 190:2010 tabular method, SHR 0.25, H = 2 m):")
print("# file room crosswise(70/50/20 70/30/20 50/50/20 50/30/20 30/30/20) endwise(same)")
for name, path in [("ugr_panel.ldt", PANEL),
                   ("wallwasher.ldt", os.path.join(ROOT, "c_examples", "data", "wallwasher.ldt"))]:
    t = UgrCalculator.compute(LdtReader.read(path)).values
    for room, row in enumerate(t):
        print("%s %d %s" % (name, room, " ".join("%.6f" % v for v in row)))
