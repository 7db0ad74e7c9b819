#!/usr/bin/env python3
"""The energy budget of finished runs (issue 37, docs/CONTACT.md, "Energy"):
for each `hookean run` output folder given, reads its steps.csv and checks
that the total energy (kinetic + gravitational + spring) never exceeds the
start's (steps.csv's first row, the end of the first step) by more than 5%
of the run's energy scale, taken as that row's
kinetic plus spring energy plus the range of its gravitational energy over
the run. The shipped scenes' colliders and pins are static, so no external
force does work and the budget is the start. Prints one CSV row per folder;
exits 1 if a run is over budget. Folders without energy columns (the
tutorial's scalar examples) are reported and skipped.

usage: scripts/energy-budget.py RUN_FOLDER...   (e.g. target/frames-ab/head-*)"""
import csv, pathlib, sys

print("run,steps,start_J,max_J,at_s,allowance_J,within")
over = False
for arg in sys.argv[1:]:
    path = pathlib.Path(arg) / "steps.csv"
    if not path.exists():
        print(f"{arg},no steps.csv,,,,,")
        continue
    rows = list(csv.DictReader(path.open()))
    if not rows or "total" not in rows[0]:
        print(f"{arg},{len(rows)},no energy columns,,,,")
        continue
    e = [float(r["total"]) for r in rows]
    g = [float(r["gravitational"]) for r in rows]
    first = rows[0]
    scale = float(first["kinetic"]) + float(first["spring"]) + (max(g) - min(g))
    allowance = 0.05 * scale
    i = max(range(len(e)), key=e.__getitem__)
    ok = e[i] <= e[0] + allowance
    over |= not ok
    print(f"{arg},{len(rows)},{e[0]:.6g},{e[i]:.6g},{float(rows[i]['t']):.6g},{allowance:.6g},{'yes' if ok else 'NO'}")
sys.exit(1 if over else 0)
