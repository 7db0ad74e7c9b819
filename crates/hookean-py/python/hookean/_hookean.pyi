"""Type stubs of the native module hookean._hookean (use hookean.sparse and hookean.ode)."""

import os
from typing import Any, Callable, Optional

import numpy as np
import numpy.typing as npt

class ConvergenceError(RuntimeError):
    """A solve or set-up that failed on valid input."""

class System:
    """A square symmetric matrix in PCG's storage."""

    @property
    def n(self) -> int: ...
    @property
    def block_size(self) -> int: ...
    @property
    def block_size_source(self) -> str: ...
    @property
    def format(self) -> str: ...
    def same_pattern(self, other: System) -> bool: ...

def system(
    n: int,
    indptr: npt.NDArray[np.int64],
    indices_: npt.NDArray[np.int64],
    data: npt.NDArray[np.float64],
    block_size: Optional[int] = None,
    nullspace: Optional[npt.NDArray[np.float64]] = None,
    coordinates: Optional[npt.NDArray[np.float64]] = None,
) -> System: ...

class Precond:
    """One of Hookean's preconditioners, set up from a System."""

    def __init__(
        self,
        name: str,
        system: System,
        omega: Optional[float] = None,
        amg: Optional[dict[str, Any]] = None,
    ) -> None: ...
    def refill(self, system: System) -> None: ...
    @property
    def setup_seconds(self) -> float: ...
    @property
    def name(self) -> str: ...
    def amg_stats(self) -> Optional[dict[str, Any]]: ...
    def apply(self, r: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def pcg(
        self,
        system: System,
        b: npt.NDArray[np.float64],
        x0: Optional[npt.NDArray[np.float64]] = None,
        rtol: float = 1e-8,
        maxiter: Optional[int] = None,
        callback: Optional[Callable[[npt.NDArray[np.float64]], object]] = None,
    ) -> tuple[npt.NDArray[np.float64], dict[str, Any]]: ...

def bdf_solve(
    fun: Callable[[float, npt.NDArray[np.float64]], npt.NDArray[np.float64]],
    jac: Optional[Callable[[float, npt.NDArray[np.float64]], npt.NDArray[np.float64]]],
    t0: float,
    y0: list[float],
    t_end: float,
    rtol: float,
    atol: list[float],
    first_step: Optional[float],
    max_step: float,
    t_eval: Optional[list[float]],
    dense: bool,
    events: list[Callable[[float, npt.NDArray[np.float64]], float]],
    directions: list[int],
    terminal: list[bool],
) -> dict[str, Any]: ...

class Scene:
    """A scene file with its key=value overrides (the facade's Scene); pickles as its path, text and overrides."""

    @staticmethod
    def from_file(path: str | os.PathLike[str], overrides: list[str] = ...) -> Scene: ...
    @staticmethod
    def from_text(path: str | os.PathLike[str], text: str, overrides: list[str]) -> Scene: ...
    def build(self) -> Simulation: ...
    @property
    def duration(self) -> float: ...
    @property
    def path(self) -> str: ...
    @property
    def overrides(self) -> list[str]: ...
    @property
    def text(self) -> str: ...

class Simulation:
    """A running simulation of a scene (the facade's Simulation)."""

    def step(self) -> float: ...
    def run_until(self, t: float, callback: Optional[Callable[[float], object]] = None) -> float: ...
    @property
    def t(self) -> float: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def velocities(self) -> npt.NDArray[np.float64]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    def write_obj(self, path: str | os.PathLike[str], overwrite: bool = False) -> None: ...
