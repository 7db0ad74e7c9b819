"""Hookean from Python: Hookean's preconditioners and PCG for ``scipy.sparse``
systems (:mod:`hookean.sparse`).

Errors are Python exceptions carrying Hookean's message: ``ValueError``
(naming the argument) for bad input, :class:`ConvergenceError` (a
``RuntimeError``) for a solve that failed on valid input.
"""

from ._hookean import ConvergenceError
from . import sparse

__all__ = ["ConvergenceError", "sparse"]
