"""Type stubs of hookean.sparse."""

from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Optional, Union

import numpy as np
import numpy.typing as npt
import scipy.sparse
import scipy.sparse.linalg

from ._hookean import ConvergenceError as ConvergenceError

PRECONDITIONERS: tuple[str, ...]
MAX_ITER: int

ArrayLike = npt.ArrayLike
Callback = Callable[[npt.NDArray[np.float64]], object]

@dataclass
class SolveInfo:
    iterations: int
    converged: bool
    relative_residual: float
    residual_history: list[float]
    setup_seconds: float
    solve_seconds: float
    precond: str
    format: str
    block_size: int
    levels: Optional[int] = ...
    operator_complexity: Optional[float] = ...
    amg: Optional[dict[str, Any]] = ...

class Preconditioner:
    name: ClassVar[str]
    def __init__(
        self,
        A: Any,
        *,
        block_size: Optional[int] = ...,
        nullspace: Optional[ArrayLike] = ...,
        coordinates: Optional[ArrayLike] = ...,
    ) -> None: ...
    @property
    def shape(self) -> tuple[int, int]: ...
    @property
    def setup_seconds(self) -> float: ...
    @property
    def format(self) -> str: ...
    @property
    def block_size(self) -> int: ...
    def refill(self, A: Any) -> Preconditioner: ...
    def apply(self, r: ArrayLike) -> npt.NDArray[np.float64]: ...
    def aslinearoperator(self) -> scipy.sparse.linalg.LinearOperator: ...
    def solve(
        self,
        b: ArrayLike,
        *,
        rtol: float = ...,
        maxiter: Optional[int] = ...,
        x0: Optional[ArrayLike] = ...,
        callback: Optional[Callback] = ...,
    ) -> tuple[npt.NDArray[np.float64], SolveInfo]: ...
    def amg_stats(self) -> Optional[dict[str, Any]]: ...

class Jacobi(Preconditioner): ...
class BlockJacobi(Preconditioner): ...
class IC0(Preconditioner): ...

class SSOR(Preconditioner):
    def __init__(self, A: Any, *, omega: float = ..., **kw: Any) -> None: ...

class MIC0(Preconditioner):
    def __init__(self, A: Any, *, omega: float = ..., **kw: Any) -> None: ...

class AMG(Preconditioner):
    def __init__(self, A: Any, *, amg: Optional[dict[str, Any]] = ..., **kw: Any) -> None: ...

def solve(
    A: Any,
    b: ArrayLike,
    *,
    precond: Union[str, Preconditioner] = ...,
    rtol: float = ...,
    maxiter: Optional[int] = ...,
    x0: Optional[ArrayLike] = ...,
    block_size: Optional[int] = ...,
    nullspace: Optional[ArrayLike] = ...,
    coordinates: Optional[ArrayLike] = ...,
    amg: Optional[dict[str, Any]] = ...,
    callback: Optional[Callback] = ...,
) -> tuple[npt.NDArray[np.float64], SolveInfo]: ...

BENCH_COLUMNS: tuple[str, ...]
BENCH_PRECONDS: tuple[str, ...]
MAX_REPEAT: int

def bench(
    matrices: Any,
    *,
    preconds: Union[str, list[str], tuple[str, ...]] = ...,
    rtol: float = ...,
    maxiter: Optional[int] = ...,
    repeat: int = ...,
    amg: Optional[dict[str, Any]] = ...,
    omega: float = ...,
) -> Any: ...
