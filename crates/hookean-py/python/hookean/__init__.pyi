from . import ode as ode
from . import sparse as sparse
from ._hookean import ConvergenceError as ConvergenceError

__all__: list[str]
