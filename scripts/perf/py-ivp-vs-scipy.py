#!/usr/bin/env python3
"""hookean.ode.solve_ivp against scipy.integrate.solve_ivp(method="BDF") with
the same Python fun and analytic jac, on Robertson and Van der Pol
(mu = 1000): best of --repeat runs, the two interleaved in one process.

    python3 scripts/perf/py-ivp-vs-scipy.py      # after pip install ./crates/hookean-py

Prints one row per problem and solver: steps (output points), nfev, njev,
nlu, best seconds, and the ratio SciPy / Hookean. --t-end-scale shortens
both intervals (e.g. 1e-3 for a quick check). Timings mean something only
on a quiet machine.
"""

import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp as scipy_solve_ivp

from hookean.ode import solve_ivp as hookean_solve_ivp


def robertson(t, y):
    return [-0.04 * y[0] + 1e4 * y[1] * y[2], 0.04 * y[0] - 1e4 * y[1] * y[2] - 3e7 * y[1] ** 2, 3e7 * y[1] ** 2]


def robertson_jac(t, y):
    return np.array(
        [[-0.04, 1e4 * y[2], 1e4 * y[1]], [0.04, -1e4 * y[2] - 6e7 * y[1], -1e4 * y[1]], [0.0, 6e7 * y[1], 0.0]]
    )


def vdp(t, y, mu=1000.0):
    return [y[1], mu * (1 - y[0] ** 2) * y[1] - y[0]]


def vdp_jac(t, y, mu=1000.0):
    return np.array([[0.0, 1.0], [-2 * mu * y[0] * y[1] - 1, mu * (1 - y[0] ** 2)]])


PROBLEMS = [
    ("robertson", robertson, robertson_jac, 4e10, [1.0, 0.0, 0.0]),
    ("vdp-1000", vdp, vdp_jac, 3000.0, [2.0, 0.0]),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs of each solver, best kept (default 5)")
    ap.add_argument("--rtol", type=float, default=1e-6, help="relative tolerance (default 1e-6)")
    ap.add_argument("--atol", type=float, default=1e-10, help="absolute tolerance (default 1e-10)")
    ap.add_argument("--t-end-scale", type=float, default=1.0, help="multiplies each t_end (default 1)")
    args = ap.parse_args()
    if args.repeat < 1 or not (0 < args.rtol < 1) or not args.atol > 0 or not args.t_end_scale > 0:
        ap.error("--repeat must be at least 1, --rtol in (0, 1), --atol and --t-end-scale positive")
    print(f"{'problem':10} {'solver':8} {'points':>7} {'nfev':>7} {'njev':>5} {'nlu':>6} {'best s':>9}")
    for name, fun, jac, t_end, y0 in PROBLEMS:
        span = (0.0, t_end * args.t_end_scale)
        kw = dict(rtol=args.rtol, atol=args.atol, jac=jac)
        runs = {
            "hookean": lambda: hookean_solve_ivp(fun, span, y0, method="BDF", **kw),
            "scipy": lambda: scipy_solve_ivp(fun, span, y0, method="BDF", **kw),
        }
        best = {s: (np.inf, None) for s in runs}
        for _ in range(args.repeat):  # interleaved: one of each per round
            for solver, run in runs.items():
                t = time.perf_counter()
                r = run()
                s = time.perf_counter() - t
                if not r.success:
                    raise SystemExit(f"{name}: {solver} failed: {r.message}")
                if s < best[solver][0]:
                    best[solver] = (s, r)
        for solver, (s, r) in best.items():
            print(f"{name:10} {solver:8} {len(r.t):7d} {r.nfev:7d} {r.njev:5d} {r.nlu:6d} {s:9.4f}")
        print(f"{name:10} {'ratio':8} scipy / hookean = {best['scipy'][0] / best['hookean'][0]:.1f}")


if __name__ == "__main__":
    main()
