#!/usr/bin/env python3
"""SciPy's solve_ivp(method="BDF") on the stiff test set of hookean_ode::testset.

Same problems, initial values, end times, reference solutions, tolerances
(atol = rtol * floor) and error measure (max_i |y_i - ref_i| / (|ref_i| + floor_i))
as crates/hookean-ode/examples/stiff_set.rs and benches/stiff-compare, with analytic Jacobians (sparse
for the spring chain). Prints the same CSV columns. Run by scripts/stiff-compare.sh.

usage: stiff_scipy.py sweep REPEATS RTOL... | stiff_scipy.py target REPEATS
"""
import math
import sys
import time

import numpy as np
import scipy
from scipy.integrate import solve_ivp
from scipy.sparse import csc_matrix


def robertson(t_end):
    def f(t, y):
        d0 = -0.04 * y[0] + 1e4 * y[1] * y[2]
        d2 = 3e7 * y[1] * y[1]
        return np.array([d0, -d0 - d2, d2])

    def jac(t, y):
        r0 = [-0.04, 1e4 * y[2], 1e4 * y[1]]
        r2 = [0.0, 6e7 * y[1], 0.0]
        r1 = [-a - b for a, b in zip(r0, r2)]
        return np.array([r0, r1, r2])

    ref = ([0.01786592114210887, 7.274751468440222e-8, 0.9821340061103758] if t_end > 1e3
           else [0.7158270687193941, 9.185534764557338e-6, 0.2841637457458413])
    name = "robertson-1e5" if t_end > 1e3 else "robertson-40"
    return name, f, jac, [1.0, 0.0, 0.0], t_end, ref, [1e-6, 1e-10, 1e-6]


def vanderpol():
    eps = 1e-6

    def f(t, y):
        return np.array([y[1], ((1 - y[0] ** 2) * y[1] - y[0]) / eps])

    def jac(t, y):
        return np.array([[0.0, 1.0], [(-2 * y[0] * y[1] - 1) / eps, (1 - y[0] ** 2) / eps]])

    return ("vanderpol-1000", f, jac, [2.0, 0.0], 2.0,
            [1.706167732170483, -0.8928097010247975], [1.0, 1.0])


def hires():
    def f(t, y):
        g = np.empty(8)
        g[0] = -1.71 * y[0] + 0.43 * y[1] + 8.32 * y[2] + 0.0007
        g[1] = 1.71 * y[0] - 8.75 * y[1]
        g[2] = -10.03 * y[2] + 0.43 * y[3] + 0.035 * y[4]
        g[3] = 8.32 * y[1] + 1.71 * y[2] - 1.12 * y[3]
        g[4] = -1.745 * y[4] + 0.43 * y[5] + 0.43 * y[6]
        g[5] = -280 * y[5] * y[7] + 0.69 * y[3] + 1.71 * y[4] - 0.43 * y[5] + 0.69 * y[6]
        g[6] = 280 * y[5] * y[7] - 1.81 * y[6]
        g[7] = -g[6]
        return g

    def jac(t, y):
        j = np.zeros((8, 8))
        j[0, :3] = [-1.71, 0.43, 8.32]
        j[1, :2] = [1.71, -8.75]
        j[2, 2:5] = [-10.03, 0.43, 0.035]
        j[3, 1:4] = [8.32, 1.71, -1.12]
        j[4, 4:7] = [-1.745, 0.43, 0.43]
        j[5, 3:8] = [0.69, 1.71, -280 * y[7] - 0.43, 0.69, -280 * y[5]]
        j[6, 5:8] = [280 * y[7], -1.81, 280 * y[5]]
        j[7, 5:8] = [-280 * y[7], 1.81, -280 * y[5]]
        return j

    ref = [0.7371312573325668e-3, 0.1442485726316185e-3, 0.5888729740967575e-4,
           0.1175651343283149e-2, 0.2386356198831331e-2, 0.6238968252742796e-2,
           0.2849998395185769e-2, 0.2850001604814231e-2]
    return "hires", f, jac, [1, 0, 0, 0, 0, 0, 0, 0.0057], 321.8122, ref, [1e-4] * 8


def orego():
    def f(t, y):
        return np.array([77.27 * (y[1] + y[0] * (1 - 8.375e-6 * y[0] - y[1])),
                         (y[2] - (1 + y[0]) * y[1]) / 77.27,
                         0.161 * (y[0] - y[2])])

    def jac(t, y):
        return np.array([[77.27 * (1 - 2 * 8.375e-6 * y[0] - y[1]), 77.27 * (1 - y[0]), 0.0],
                         [-y[1] / 77.27, -(1 + y[0]) / 77.27, 1 / 77.27],
                         [0.161, 0.0, -0.161]])

    return ("orego", f, jac, [1.0, 2.0, 3.0], 360.0,
            [0.1000814870318523e1, 0.1228178521549917e4, 0.1320554942846706e3], [1.0] * 3)


def e5():
    A, B, C, M = 7.89e-10, 1.1e7, 1.13e3, 1e6

    def f(t, y):
        p1, p2, p3, p4 = A * y[0], B * y[0] * y[2], M * C * y[1] * y[2], C * y[3]
        f0, f1, f3 = -p1 - p2, p1 - p3, p2 - p4
        return np.array([f0, f1, f1 - f3, f3])

    def jac(t, y):
        r0 = [-A - B * y[2], 0.0, -B * y[0], 0.0]
        r1 = [A, -M * C * y[2], -M * C * y[1], 0.0]
        r3 = [B * y[2], 0.0, B * y[0], -C]
        r2 = [a - b for a, b in zip(r1, r3)]
        return np.array([r0, r1, r2, r3])

    ref = [0.1152903278711829e-290, 0.8867655517642120e-22, 0.8854814626268838e-22, 0.0]
    return "e5", f, jac, [1.76e-3, 0.0, 0.0, 0.0], 1e13, ref, [1e-18] * 4


def spring_chain(reference):
    n = 50
    k = np.array([1e4 if i % 2 == 0 else 1.0 for i in range(n + 1)])
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] = k[i] + (k[i + 1] if i + 1 < n else 0.0)
        if i > 0:
            K[i, i - 1] = -k[i]
        if i + 1 < n:
            K[i, i + 1] = -k[i + 1]
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -K
    A[n:, n:] = -0.01 * K
    As = csc_matrix(A)

    def f(t, y):
        return As @ y

    def jac(t, y):
        return As

    y0 = np.zeros(2 * n)
    y0[:n] = np.sin(np.pi * np.arange(1, n + 1) / n)
    return "spring-chain-50-sparse", f, jac, y0, 10.0, reference, [1e-3] * (2 * n)


def run(problem, rtol):
    name, f, jac, y0, t_end, ref, floor = problem
    atol = np.array(floor) * rtol
    start = time.perf_counter()
    sol = solve_ivp(f, (0.0, t_end), y0, method="BDF", rtol=rtol, atol=atol, jac=jac)
    wall = time.perf_counter() - start
    if not sol.success:
        return None, wall
    y = sol.y[:, -1]
    err = max(abs(a - r) / (abs(r) + fl) for a, r, fl in zip(y, ref, floor))
    return (err, len(sol.t) - 1, sol.njev, sol.nlu, sol.nfev), wall


def median_time(problem, rtol, repeats):
    times = sorted(run(problem, rtol)[1] for _ in range(max(repeats, 1)))
    return times[len(times) // 2]


def main():
    """Modes: `sweep REPEATS RTOL...` prints one row per problem and rtol;
    `target REPEATS` walks the rtol ladder 1e-2, 3e-3, ..., 1e-10 until the
    error is <= 1e-4 and prints that rung with the time at 1e-4 interpolated
    (log time linear in log error between the rungs around the target), as
    benches/stiff-compare does for the Rust solvers."""
    mode = sys.argv[1] if len(sys.argv) > 1 else "sweep"
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    rtols = [float(a) for a in sys.argv[3:]] or [1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
    # The chain is linear: its reference is exp(10 A) y0 (scipy.linalg.expm).
    from scipy.linalg import expm
    _, _, jac, y0, t_end, _, _ = spring_chain(None)
    chain_ref = list(expm(t_end * jac(0, y0).toarray()) @ y0)
    problems = [robertson(40.0), robertson(1e5), vanderpol(), hires(), orego(), e5(),
                spring_chain(chain_ref)]
    print(f"# scipy {scipy.__version__}, numpy {np.__version__}", file=sys.stderr)
    if mode == "sweep":
        print("problem,rtol,error,steps,rhs_evals,jac_evals,lu_setups,wall_s,status", flush=True)
        for rtol in rtols:
            for problem in problems:
                res, _ = run(problem, rtol)
                wall = median_time(problem, rtol, repeats)
                if res is None:
                    print(f"{problem[0]},{rtol:e},inf,,,,,{wall:.6e},failed", flush=True)
                    continue
                err, steps, njev, nlu, nfev = res
                print(f"{problem[0]},{rtol:e},{err:.3e},{steps},{nfev},{njev},{nlu},{wall:.6e},ok",
                      flush=True)
        return
    target = 1e-4
    ladder = []
    for e in range(2, 11):
        ladder.append(10.0 ** -e)
        if e < 10:
            ladder.append(0.3 * 10.0 ** -e)
    print("problem,solver,rtol,error,steps,jac_evals,lu_setups,rhs_evals,wall_s,wall_s_at_1e-4",
          flush=True)
    for problem in problems:
        above = None
        for rtol in ladder:
            res, _ = run(problem, rtol)
            if res is None:
                continue
            err, steps, njev, nlu, nfev = res
            wall = median_time(problem, rtol, repeats)
            if not err <= target:
                above = (err, wall)
                continue
            at = wall
            if above is not None and err > 0:
                w = (math.log(target) - math.log(above[0])) / (math.log(err) - math.log(above[0]))
                at = math.exp(math.log(above[1]) + w * (math.log(wall) - math.log(above[1])))
            print(f"{problem[0]},scipy,{rtol:e},{err:.3e},{steps},{njev},{nlu},{nfev},{wall:.6e},{at:.6e}",
                  flush=True)
            break


if __name__ == "__main__":
    main()
