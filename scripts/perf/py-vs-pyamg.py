#!/usr/bin/env python3
"""hookean.sparse.solve against pyamg's smoothed_aggregation_solver(...) set-up
plus .solve(...) (CG acceleration) to the same tolerance, on pyamg's gallery
systems: best of --repeat runs, the two interleaved in one process.

    python3 scripts/perf/py-vs-pyamg.py --size 200     # after pip install ./crates/hookean-py pyamg

Prints one row per system and solver: unknowns, iterations, best set-up +
solve seconds, the true relative residual |b - A x| / |b|, and for Hookean
the share of its best run spent outside the set-up and solve Rust timed
(the conversion of A and b, the checks, the calls). Timings mean
something only on a quiet machine.
"""

import argparse
import time

import numpy as np
import pyamg

import hookean.sparse as hs


def elasticity_3d(n):
    """pyamg's P1 elasticity on the unit cube (n^3 cubes of 6 tets), clamped at x = 0."""
    g = np.linspace(0.0, 1.0, n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    vertices = np.c_[x.ravel(), y.ravel(), z.ravel()]
    idx = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)
    i, j, k = (a.ravel() for a in np.meshgrid(*(np.arange(n),) * 3, indexing="ij"))
    c = [idx(i + a, j + b, k + d) for d in (0, 1) for b in (0, 1) for a in (0, 1)]
    tets = np.concatenate(
        [np.c_[c[0], c[p], c[q], c[7]] for p, q in ((1, 3), (3, 2), (2, 6), (6, 4), (4, 5), (5, 1))]
    )
    A, B = pyamg.gallery.linear_elasticity_p1(vertices, tets, format="csr")
    free = np.repeat(vertices[:, 0] > 0.0, 3)
    return A.tocsr()[free][:, free].tocsr(), np.ascontiguousarray(B[free])


def systems(size):
    """(name, A, near-nullspace) of about size^2 unknowns (2D) or size^3 / 8 (3D)."""
    A, B = pyamg.gallery.linear_elasticity((size, size), format="bsr")
    yield "elasticity-2d", A.tocsr(), B
    n3 = max(2, size // 8)
    A, B = elasticity_3d(n3)
    yield "elasticity-3d", A, B
    A = pyamg.gallery.poisson((size // 4,) * 3, format="csr")
    yield "poisson-3d", A, None
    d = pyamg.gallery.load_example("local_disc_galerkin_diffusion")
    yield "dg-diffusion", d["A"].tocsr(), np.ascontiguousarray(d["B"], dtype=np.float64)


def run_hookean(A, b, B, rtol):
    t = time.perf_counter()
    x, info = hs.solve(A, b, precond="amg", nullspace=B, rtol=rtol)
    wall = time.perf_counter() - t
    # What Python adds: the conversion, the checks and the calls, beyond the
    # set-up and the PCG solve Rust timed.
    overhead = wall - info.setup_seconds - info.solve_seconds
    return wall, info.iterations, x, overhead


def run_pyamg(A, b, B, rtol):
    t = time.perf_counter()
    ml = pyamg.smoothed_aggregation_solver(A, B=B)
    res = []
    x = ml.solve(b, tol=rtol, accel="cg", residuals=res)
    return time.perf_counter() - t, len(res) - 1, x, None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=200, help="grid size (default 200)")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each solver, best kept (default 5)")
    ap.add_argument("--rtol", type=float, default=1e-8, help="relative residual tolerance (default 1e-8)")
    args = ap.parse_args()
    if args.size < 4 or args.repeat < 1 or not (0 < args.rtol < 1):
        ap.error("--size must be at least 4, --repeat at least 1, --rtol in (0, 1)")
    print(f"{'system':14} {'solver':8} {'unknowns':>9} {'iters':>6} {'best s':>9} {'residual':>9}"
          f" {'overhead':>9}")
    for name, A, B in systems(args.size):
        b = np.random.default_rng(0).standard_normal(A.shape[0])
        best = {"hookean": (np.inf, 0, None, None), "pyamg": (np.inf, 0, None, None)}
        for _ in range(args.repeat):  # interleaved: one of each per round
            for solver, run in (("hookean", run_hookean), ("pyamg", run_pyamg)):
                r = run(A, b, B, args.rtol)
                if r[0] < best[solver][0]:
                    best[solver] = r
        for solver, (s, its, x, overhead) in best.items():
            res = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
            share = "" if overhead is None else f" {100 * overhead / s:8.2f}%"
            print(f"{name:14} {solver:8} {A.shape[0]:9d} {its:6d} {s:9.4f} {res:9.2e}{share}")


if __name__ == "__main__":
    main()
