"""Robertson's stiff chemistry with Hookean's BDF: SciPy's solve_ivp, one import changed."""
import numpy as np
from hookean.ode import solve_ivp  # was: from scipy.integrate import solve_ivp


def f(t, y):
    return [-0.04 * y[0] + 1e4 * y[1] * y[2], 0.04 * y[0] - 1e4 * y[1] * y[2] - 3e7 * y[1] ** 2, 3e7 * y[1] ** 2]


t_eval = np.logspace(-5, 10, 7)
r = solve_ivp(f, (0.0, 1e10), [1.0, 0.0, 0.0], method="BDF", t_eval=t_eval, rtol=1e-6, atol=1e-10)
print(r.message, f"nfev={r.nfev} njev={r.njev} nlu={r.nlu}")
for t, y in zip(r.t, r.y.T):
    print(f"t = {t:8.1e}  y = {y[0]:.6f} {y[1]:.4e} {y[2]:.6f}  sum - 1 = {y.sum() - 1:+.1e}")
