from . import ode as ode
from . import sparse as sparse
from ._hookean import ConvergenceError as ConvergenceError
from ._hookean import Scene as Scene
from ._hookean import Simulation as Simulation

__all__: list[str]
