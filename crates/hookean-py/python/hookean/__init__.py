"""Hookean from Python: Hookean's preconditioners and PCG for ``scipy.sparse``
systems (:mod:`hookean.sparse`), and stiff initial value problems on its
variable-order BDF with SciPy's ``solve_ivp`` interface (:mod:`hookean.ode`).

Errors are Python exceptions carrying Hookean's message: ``ValueError``
(naming the argument) for bad input, :class:`ConvergenceError` (a
``RuntimeError``) for a solve that failed on valid input.
"""

from ._hookean import ConvergenceError
from . import ode, sparse

__all__ = ["ConvergenceError", "ode", "sparse"]
