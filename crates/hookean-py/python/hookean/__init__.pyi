from . import builders as builders
from . import ode as ode
from . import sparse as sparse
from ._hookean import ConvergenceError as ConvergenceError
from ._hookean import Scene as Scene
from ._hookean import Simulation as Simulation
from .builders import cloth as cloth
from .builders import jelly as jelly
from .builders import rope as rope

__all__: list[str]
