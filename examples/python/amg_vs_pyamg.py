"""Hookean's AMG against pyamg's on pyamg's gallery: iterations and seconds to 1e-8."""
import time, numpy as np, pyamg, hookean.sparse as hs

A, B = pyamg.gallery.linear_elasticity((120, 120), format="bsr")  # 2D, rigid-body modes B
b = np.random.default_rng(0).standard_normal(A.shape[0])
t = time.perf_counter()
x, info = hs.solve(A, b, precond="amg", nullspace=B, rtol=1e-8)
t_hookean = time.perf_counter() - t
t = time.perf_counter()
ml = pyamg.smoothed_aggregation_solver(A, B=B)
res = []
y = ml.solve(b, tol=1e-8, accel="cg", residuals=res)
t_pyamg = time.perf_counter() - t
for name, z, its, s in [("hookean", x, info.iterations, t_hookean), ("pyamg", y, len(res) - 1, t_pyamg)]:
    r = np.linalg.norm(b - A @ z) / np.linalg.norm(b)
    print(f"{name:8} {its:4d} iterations  {s:.3f} s  |b - A x| / |b| = {r:.2e}")
