from typing import Any, Callable, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt
from scipy.integrate import DenseOutput, OdeSolution
from scipy.optimize import OptimizeResult

_Array = npt.NDArray[np.float64]
_Fun = Callable[..., npt.ArrayLike]

class OdeResult(OptimizeResult):
    t: _Array
    y: _Array
    sol: Optional[OdeSolution]
    t_events: Optional[list[_Array]]
    y_events: Optional[list[_Array]]
    nfev: int
    njev: int
    nlu: int
    status: int
    message: str
    success: bool
    stats: dict[str, int]

class StepPolynomial(DenseOutput):
    def __init__(self, t_old: float, t: float, nodes_t: _Array, nodes_y: _Array) -> None: ...

def solve_ivp(
    fun: _Fun,
    t_span: Sequence[float],
    y0: npt.ArrayLike,
    method: str = "BDF",
    t_eval: Optional[npt.ArrayLike] = None,
    dense_output: bool = False,
    events: Union[None, Callable[..., float], Sequence[Callable[..., float]]] = None,
    vectorized: bool = False,
    args: Optional[Any] = None,
    rtol: float = 1e-3,
    atol: Union[float, npt.ArrayLike] = 1e-6,
    jac: Union[None, _Fun, npt.ArrayLike, Any] = None,
    jac_sparsity: Optional[Any] = None,
    first_step: Optional[float] = None,
    max_step: float = ...,
) -> OdeResult: ...
