#!/usr/bin/env python3
"""Writes data/table.obj, the table of scenes/cloth-table.toml: a 0.6 m x 0.6 m
top, 4 cm thick, at height 0.5 m on four 5 cm legs; five closed boxes with
outward counter-clockwise quads."""
import pathlib

def box(lo, hi, base):
    v = [(lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
          lo[2] if i & 4 == 0 else hi[2]) for i in range(8)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return v, [tuple(base + i + 1 for i in q) for q in quads]

parts = [((-0.3, -0.3, 0.46), (0.3, 0.3, 0.5))]
for sx in (-1, 1):
    for sy in (-1, 1):
        x0, y0 = 0.25 * sx - 0.025, 0.25 * sy - 0.025
        parts.append(((x0, y0, 0.0), (x0 + 0.05, y0 + 0.05, 0.46)))
lines = ["# A table for scenes/cloth-table.toml: a 0.6 m x 0.6 m top, 4 cm thick, at",
         "# height 0.5 m on four 5 cm legs; five closed boxes, faces counter-clockwise",
         "# seen from outside (quads, triangulated by the reader). Written by hand",
         "# (scripts/table-obj.py) for the Hookean project."]
vs, fs = [], []
for lo, hi in parts:
    v, f = box(lo, hi, len(vs))
    vs += v
    fs += f
lines += ["v %g %g %g" % p for p in vs] + ["f %d %d %d %d" % q for q in fs]
root = pathlib.Path(__file__).resolve().parent.parent
(root / "data/table.obj").write_text("\n".join(lines) + "\n")
