"""Hookean from Python: Hookean's preconditioners and PCG for ``scipy.sparse``
systems (:mod:`hookean.sparse`), and stiff initial value problems on its
variable-order BDF with SciPy's ``solve_ivp`` interface (:mod:`hookean.ode`),
and scene files run by the facade (:class:`Scene`, :class:`Simulation`)::

    sim = hookean.Scene.from_file("scenes/drape.toml", overrides=["cloth.n=16"]).build()
    sim.run_until(0.5)
    sim.positions          # (n, 3) NumPy array
    hookean.cloth(n=32, stiffness=2e4, integrator={"method": "bdf"}).build()

Errors are Python exceptions carrying Hookean's message: ``ValueError``
(naming the argument) for bad input, :class:`ConvergenceError` (a
``RuntimeError``) for a solve that failed on valid input.
"""

from ._hookean import ConvergenceError, Scene, Simulation
from . import ode, sparse
from .builders import cloth, jelly, rope

__all__ = ["ConvergenceError", "Scene", "Simulation", "cloth", "jelly", "ode", "rope", "sparse"]
