"""Hookean's PCG and preconditioners on ``scipy.sparse`` matrices.

``solve(A, b)`` takes the path of the command line's ``hookean solve``: the
matrix is converted once, checked square, finite and symmetric, stored as
3x3 blocks when its nodes have 3 unknowns and it allows them (else CSR with
the unknowns per node the multigrid and block Jacobi group), and solved by
PCG with one of Hookean's preconditioners.

>>> import numpy as np, scipy.sparse as sp, hookean.sparse as hs
>>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(50, 50), format="csr")
>>> x, info = hs.solve(A, np.ones(50), precond="ic0", rtol=1e-10)
>>> bool(info.converged), bool(np.linalg.norm(A @ x - 1) <= 1e-10 * np.sqrt(50))
(True, True)
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from . import _hookean
from ._hookean import ConvergenceError

__all__ = [
    "solve",
    "SolveInfo",
    "Jacobi",
    "BlockJacobi",
    "SSOR",
    "IC0",
    "MIC0",
    "AMG",
    "PRECONDITIONERS",
    "bench",
    "BENCH_COLUMNS",
]

#: The preconditioner names ``solve`` takes.
PRECONDITIONERS = ("none", "jacobi", "block-jacobi", "ssor", "ic0", "mic0", "amg")

#: The largest ``maxiter`` (the command line's ``--max-iter`` bound).
MAX_ITER = 10_000_000


@dataclass
class SolveInfo:
    """What a solve did.

    Attributes:
        iterations: PCG iterations.
        converged: whether the true residual met ``rtol``.
        relative_residual: ``|b - A x| / |b|`` at PCG's stop.
        residual_history: PCG's recursive ``|r| / |b|``, 1 at the start, then
            after each iteration.
        setup_seconds: the preconditioner's set-up (0 for one given built).
        solve_seconds: PCG.
        precond: the preconditioner's name.
        format: the storage PCG ran on, ``sym-block-3x3`` or ``csr``.
        block_size: unknowns per node (3 on block storage).
        levels: the multigrid's levels (``None`` for another preconditioner).
        operator_complexity: the multigrid's operator complexity, nonzeros of
            every level over the finest's (``None`` for another).
        amg: the multigrid's hierarchy (rows and nonzeros per level, grid
            complexity), or ``None``.
    """

    iterations: int
    converged: bool
    relative_residual: float
    residual_history: list = field(repr=False)
    setup_seconds: float
    solve_seconds: float
    precond: str
    format: str
    block_size: int
    levels: int | None = None
    operator_complexity: float | None = None
    amg: dict | None = field(default=None, repr=False)


def _system(A, *, block_size=None, nullspace=None, coordinates=None, name="A"):
    """``A`` (any scipy.sparse matrix or array) converted once into Hookean's storage."""
    if not scipy.sparse.issparse(A):
        raise ValueError(
            f"{name}: expected a scipy.sparse matrix or array (CSR, CSC, COO, BSR, ...), "
            f"got {type(A).__name__}"
        )
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"{name}: the matrix is not square ({' x '.join(map(str, A.shape))})")
    if A.dtype not in (np.float64, np.float32):
        raise ValueError(f"{name}: expected float64 or float32 entries, got {A.dtype}")
    A = A.tocsr(copy=False)
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    # int32 or int64 as they are (Rust reads both); other widths widened.
    indptr, indices = (
        np.ascontiguousarray(v, dtype=v.dtype if v.dtype in (np.int32, np.int64) else np.int64)
        for v in (A.indptr, A.indices)
    )
    data = np.ascontiguousarray(A.data, dtype=np.float64)
    if block_size is not None and (
        isinstance(block_size, bool) or not isinstance(block_size, numbers.Integral)
    ):
        raise ValueError(f"block_size: must be 1, 2 or 3, got {block_size!r}")
    ns = _matrix_arg(nullspace, "nullspace")
    coords = _matrix_arg(coordinates, "coordinates")
    return _hookean.system(
        A.shape[0],
        indptr,
        indices,
        data,
        None if block_size is None else int(block_size),
        ns,
        coords,
    )


def _matrix_arg(v, name):
    """An optional 2D float64 array argument (a 1D one is one column)."""
    if v is None:
        return None
    try:
        v = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: expected an array of numbers ({e})") from None
    if v.ndim == 1:
        v = v[:, None]
    if v.ndim != 2:
        raise ValueError(f"{name}: expected a 2D array, got {v.ndim} dimensions")
    return np.ascontiguousarray(v)


def _vector(v, name, n):
    """A float64 vector argument of ``n`` entries."""
    if scipy.sparse.issparse(v):
        v = v.toarray()
    try:
        v = np.asarray(v)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: expected an array of numbers ({e})") from None
    if v.dtype.kind not in "fiu" or v.dtype == np.float16:
        raise ValueError(f"{name}: expected real numbers (float64, float32 or int), got {v.dtype}")
    if v.ndim == 2 and 1 in v.shape:
        v = v.reshape(-1)
    if v.ndim != 1 or v.shape[0] != n:
        raise ValueError(f"{name}: expected shape ({n},), got {v.shape}")
    return np.ascontiguousarray(v, dtype=np.float64)


def _check_rtol(rtol):
    if isinstance(rtol, bool) or not isinstance(rtol, numbers.Real):
        raise ValueError(f"rtol: expected a number, got {rtol!r}")
    if not (0.0 <= rtol < 1.0):
        raise ValueError(f"rtol: must lie in [0, 1), got {rtol}")
    return float(rtol)


def _check_maxiter(maxiter):
    if maxiter is None:
        return None
    if isinstance(maxiter, bool) or not isinstance(maxiter, numbers.Integral):
        raise ValueError(f"maxiter: expected an integer, got {maxiter!r}")
    if not (0 <= maxiter <= MAX_ITER):
        raise ValueError(f"maxiter: must lie in 0 to {MAX_ITER}, got {maxiter}")
    return int(maxiter)


class Preconditioner:
    """One of Hookean's preconditioners, built once from a symmetric matrix.

    ``refill(A)`` sets it up again from new values of the same pattern,
    ``aslinearoperator()`` applies ``M^-1`` for ``scipy.sparse.linalg``
    (``cg(A, b, M=AMG(A).aslinearoperator())``), and ``solve(b)`` runs
    Hookean's PCG with it on the matrix it was built from.
    """

    #: The name ``solve``'s ``precond`` takes.
    name = "none"

    def __init__(self, A, *, block_size=None, nullspace=None, coordinates=None, _options=None):
        self._nodes = dict(block_size=block_size, nullspace=nullspace, coordinates=coordinates)
        self._system = _system(A, **self._nodes)
        self._options = dict(_options or {})
        self._p = _hookean.Precond(self.name, self._system, **self._options)

    @property
    def shape(self):
        """``(n, n)``."""
        return (self._system.n, self._system.n)

    @property
    def setup_seconds(self):
        """Seconds of the last set-up or refill."""
        return self._p.setup_seconds

    @property
    def format(self):
        """The storage: ``sym-block-3x3`` or ``csr``."""
        return self._system.format

    @property
    def block_size(self):
        """Unknowns per node (3 on block storage)."""
        return self._system.block_size

    def refill(self, A):
        """Sets the preconditioner up again from ``A``: new values, the same pattern."""
        system = _system(A, **self._nodes)
        if not self._system.same_pattern(system):
            raise ValueError(
                "A: refill needs the sparsity pattern the preconditioner was built from "
                "(build a new preconditioner for another pattern)"
            )
        self._p.refill(system)
        self._system = system
        return self

    def apply(self, r):
        """``M^-1 r``."""
        return self._p.apply(_vector(r, "r", self._system.n))

    def aslinearoperator(self):
        """``M^-1`` as a ``scipy.sparse.linalg.LinearOperator``."""
        n = self._system.n
        return scipy.sparse.linalg.LinearOperator(
            (n, n), matvec=lambda r: self._p.apply(_vector(r, "r", n)), dtype=np.float64
        )

    def solve(self, b, *, rtol=1e-8, maxiter=None, x0=None, callback=None):
        """PCG with this preconditioner on the matrix it was built (or refilled) from.

        Returns ``(x, SolveInfo)``; raises :class:`hookean.ConvergenceError`
        when PCG does not reach ``rtol`` within ``maxiter`` (default 2 n)
        iterations, with the last ``x`` and ``SolveInfo`` as its ``x`` and
        ``info``. ``callback(xk)`` is called after each iteration.
        """
        return _pcg(self, b, rtol, maxiter, x0, callback, setup_seconds=0.0)

    def amg_stats(self):
        """The multigrid's hierarchy, or ``None``."""
        return self._p.amg_stats()


def _pcg(P, b, rtol, maxiter, x0, callback, setup_seconds, system=None):
    system = P._system if system is None else system
    n = system.n
    rtol = _check_rtol(rtol)
    maxiter = _check_maxiter(maxiter)
    b = _vector(b, "b", n)
    x0 = None if x0 is None else _vector(x0, "x0", n)
    if callback is not None and not callable(callback):
        raise ValueError(f"callback: expected a callable, got {type(callback).__name__}")
    x, d = P._p.pcg(system, b, x0, rtol, maxiter, callback)
    amg = P._p.amg_stats()
    info = SolveInfo(
        setup_seconds=setup_seconds,
        precond=P._p.name,
        format=system.format,
        block_size=system.block_size,
        levels=None if amg is None else amg["levels"],
        operator_complexity=None if amg is None else amg["operator_complexity"],
        amg=amg,
        **d,
    )
    if not info.converged:
        e = ConvergenceError(
            f"PCG ({info.precond}) did not reach rtol {rtol:g} in {info.iterations} "
            f"iterations: |b - A x| / |b| = {info.relative_residual:.6g} (raise maxiter, "
            "or try another precond)"
        )
        e.x, e.info = x, info
        raise e
    return x, info


class Jacobi(Preconditioner):
    """Diagonal (point-Jacobi) preconditioner ``M = diag(A)``."""

    name = "jacobi"


class BlockJacobi(Preconditioner):
    """Block-Jacobi: the diagonal blocks of ``A``, one per node of ``block_size``
    unknowns (1, 2 or 3; given, or from ``nullspace``, ``coordinates`` or the
    pattern, as for :class:`AMG`; 3 on block storage)."""

    name = "block-jacobi"


class SSOR(Preconditioner):
    """Symmetric successive over-relaxation with relaxation ``omega`` in (0, 2)."""

    name = "ssor"

    def __init__(self, A, *, omega=1.0, **kw):
        super().__init__(A, _options=dict(omega=float(omega)), **kw)


class IC0(Preconditioner):
    """Incomplete Cholesky without fill-in, IC(0)."""

    name = "ic0"


class MIC0(Preconditioner):
    """Modified IC(0) (3x3 block storage only), relaxation ``omega`` in [0, 1]."""

    name = "mic0"

    def __init__(self, A, *, omega=0.99, **kw):
        super().__init__(A, _options=dict(omega=float(omega)), **kw)


class AMG(Preconditioner):
    """Smoothed-aggregation algebraic multigrid (one V-cycle per application).

    ``block_size`` (1, 2 or 3 unknowns per node), ``nullspace`` (an ``(n, k)``
    array of near-nullspace vectors, e.g. rigid-body modes) or
    ``coordinates`` (an ``(n / d, d)`` array of node coordinates, whose
    rigid-body modes become the near-nullspace) describe the nodes; ``amg``
    is a dictionary of the multigrid's options (strength_threshold,
    coarse_size, max_levels, smoother, sweeps, jacobi_weight,
    prolongation_weight, power_iterations, precision).
    """

    name = "amg"

    def __init__(self, A, *, amg=None, **kw):
        if amg is not None and not isinstance(amg, dict):
            raise ValueError(f"amg: expected a dict of options, got {type(amg).__name__}")
        super().__init__(A, _options=dict(amg=amg), **kw)


_CLASSES = {c.name: c for c in (Jacobi, BlockJacobi, SSOR, IC0, MIC0, AMG)}


class _Identity(Preconditioner):
    name = "none"


_CLASSES["none"] = _Identity


def solve(
    A,
    b,
    *,
    precond="amg",
    rtol=1e-8,
    maxiter=None,
    x0=None,
    block_size=None,
    nullspace=None,
    coordinates=None,
    amg=None,
    callback=None,
):
    """Solves the symmetric positive definite system ``A x = b`` by PCG.

    Args:
        A: any ``scipy.sparse`` matrix or array (CSR, CSC, COO, BSR; float64
            or float32; int32 or int64 indices), square and symmetric.
        b: the right-hand side, ``n`` numbers.
        precond: ``"amg"`` (default), ``"ic0"``, ``"mic0"``, ``"ssor"``,
            ``"jacobi"``, ``"block-jacobi"`` or ``"none"``, or a
            :class:`Preconditioner` already built (from ``A`` or a matrix
            of its size): PCG on ``A`` with it, no set-up.
        rtol: relative residual tolerance ``|b - A x| / |b|``, in [0, 1).
        maxiter: PCG iteration limit (default 2 n).
        x0: the starting point (default zero).
        block_size: unknowns per node (1, 2 or 3); default from
            ``nullspace``, ``coordinates`` or the pattern, as ``hookean solve``.
        nullspace: the multigrid's near-nullspace, an ``(n, k)`` array.
        coordinates: node coordinates ``(n / d, d)``; their rigid-body modes
            become the multigrid's near-nullspace.
        amg: the multigrid's options (see :class:`AMG`).
        callback: ``callback(xk)`` after each iteration; an exception it
            raises stops the solve and propagates.

    Returns:
        ``(x, SolveInfo)``.

    Raises:
        ValueError: bad input, naming the argument.
        hookean.ConvergenceError: PCG did not reach ``rtol`` (its ``x`` and
            ``info`` attributes hold the last iterate), or the preconditioner
            broke down, on valid input.
    """
    if isinstance(precond, Preconditioner):
        system = _system(A, **precond._nodes)
        if system.n != precond.shape[0]:
            raise ValueError(f"precond: built for shape {precond.shape}, A has {(system.n,) * 2}")
        return _pcg(precond, b, rtol, maxiter, x0, callback, setup_seconds=0.0, system=system)
    if not isinstance(precond, str) or precond not in _CLASSES:
        raise ValueError(
            f"precond: unknown preconditioner {precond!r} (expected {', '.join(PRECONDITIONERS)}, "
            "or a hookean.sparse preconditioner)"
        )
    # Checked before the set-up, which can be long.
    _check_rtol(rtol)
    _check_maxiter(maxiter)
    kw = dict(block_size=block_size, nullspace=nullspace, coordinates=coordinates)
    if precond == "amg":
        P = AMG(A, amg=amg, **kw)
    else:
        if amg is not None:
            raise ValueError(f"amg: multigrid options given with precond={precond!r}")
        P = _CLASSES[precond](A, **kw)
    return _pcg(P, b, rtol, maxiter, x0, callback, setup_seconds=P.setup_seconds)


#: The columns of a :func:`bench` row: those of ``hookean bench``'s ``bench.csv``.
BENCH_COLUMNS = (
    "system",
    "rows",
    "nonzeros",
    "block_size",
    "block_size_source",
    "preconditioner",
    "iterations",
    "setup_s",
    "solve_s",
    "total_s",
    "rel_residual",
    "recursive_rel_residual",
    "setup_memory_bytes",
    "lambda_min",
    "lambda_max",
    "condition",
    "status",
)

#: ``bench``'s default preconditioners: ``hookean bench``'s, without ``direct``.
BENCH_PRECONDS = ("jacobi", "block-jacobi", "ssor", "ic0", "amg")

#: The most rounds (``hookean bench --repeat``'s bound).
MAX_REPEAT = 1000


def _bench_systems(matrices):
    """``matrices`` as a list of ``(name, A, b, nodes)``.

    Takes a dict ``{name: A}`` or ``{name: (A, b)}`` or
    ``{name: dict(A=..., b=..., nullspace=..., coordinates=..., block_size=...)}``,
    or a list of such values (named ``system-0``, ``system-1``, ...).
    """
    if isinstance(matrices, dict):
        items = list(matrices.items())
    elif scipy.sparse.issparse(matrices):
        items = [("system-0", matrices)]
    else:
        try:
            items = [(f"system-{k}", v) for k, v in enumerate(matrices)]
        except TypeError:
            raise ValueError(
                "matrices: expected a dict {name: A}, a list of matrices, or one matrix, "
                f"got {type(matrices).__name__}"
            ) from None
    if not items:
        raise ValueError("matrices: no systems given")
    out = []
    for name, v in items:
        if not isinstance(name, str):
            raise ValueError(f"matrices: system names must be strings, got {name!r}")
        nodes = {}
        if isinstance(v, dict):
            unknown = set(v) - {"A", "b", "nullspace", "coordinates", "block_size"}
            if unknown or "A" not in v:
                raise ValueError(
                    f"matrices[{name!r}]: expected keys A, b, nullspace, coordinates, "
                    f"block_size (A required), got {sorted(v)}"
                )
            A, b = v["A"], v.get("b")
            nodes = {k: v[k] for k in ("nullspace", "coordinates", "block_size") if k in v}
        elif isinstance(v, tuple):
            if len(v) != 2:
                raise ValueError(f"matrices[{name!r}]: expected (A, b), got {len(v)} items")
            A, b = v
        else:
            A, b = v, None
        out.append((name, A, b, nodes))
    return out


def bench(
    matrices,
    *,
    preconds=BENCH_PRECONDS,
    rtol=1e-8,
    maxiter=None,
    repeat=3,
    amg=None,
    omega=1.0,
):
    """Every preconditioner on every system, in interleaved rounds: ``hookean bench`` from Python.

    Each round runs every preconditioner once, in order, on a system (set-up
    and PCG solve); a row holds the best set-up and the best solve time over
    the rounds, so that a slow first round (caches, page faults) does not
    decide. A system that cannot be used (not square, not symmetric, not
    finite) and a preconditioner that fails on it (no convergence, a
    breakdown, MIC(0) on CSR storage) are rows whose ``status`` says why;
    bad arguments raise ``ValueError``.

    Args:
        matrices: ``{name: A}``, ``{name: (A, b)}`` or ``{name: dict(A=...,
            b=..., nullspace=..., coordinates=..., block_size=...)}``, or a
            list of matrices. ``b`` defaults to ``A @ ones``, as in ``hookean
            bench``.
        preconds: names from :data:`PRECONDITIONERS` (default
            :data:`BENCH_PRECONDS`).
        rtol: PCG's relative residual tolerance, in [0, 1).
        maxiter: PCG's iteration limit (default 2 n).
        repeat: rounds, 1 to 1000.
        amg: the multigrid's options (see :class:`AMG`).
        omega: SSOR's relaxation.

    Returns:
        A list of dicts with the columns of ``bench.csv``
        (:data:`BENCH_COLUMNS`), one per system and preconditioner, or a
        ``pandas.DataFrame`` of them when pandas is importable.
        ``setup_memory_bytes`` is ``None``: the command line measures it
        with its own heap counter, which a Python process does not have;
        ``lambda_min``, ``lambda_max`` and ``condition`` (the command's
        condition estimate from PCG's coefficients) are ``None`` too.

    >>> import scipy.sparse as sp, hookean.sparse as hs
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(200, 200), format="csr")
    >>> rows = hs.bench({"laplace-1d": A}, preconds=["jacobi", "ic0"], repeat=1)
    >>> [(r["preconditioner"], r["status"]) for r in list(getattr(rows, "to_dict", lambda _: rows)("records"))]
    [('jacobi', 'converged'), ('ic0', 'converged')]
    """
    if isinstance(preconds, str):
        preconds = [p.strip() for p in preconds.split(",")]
    preconds = list(preconds)
    if not preconds:
        raise ValueError("preconds: no preconditioner given")
    for p in preconds:
        if p not in _CLASSES:
            raise ValueError(
                f"preconds: unknown preconditioner {p!r} (expected {', '.join(PRECONDITIONERS)})"
            )
    if len(set(preconds)) != len(preconds):
        raise ValueError(f"preconds: a preconditioner is named twice in {preconds}")
    _check_rtol(rtol)
    _check_maxiter(maxiter)
    if isinstance(repeat, bool) or not isinstance(repeat, numbers.Integral):
        raise ValueError(f"repeat: expected an integer, got {repeat!r}")
    if not (1 <= repeat <= MAX_REPEAT):
        raise ValueError(f"repeat: must lie in 1 to {MAX_REPEAT}, got {repeat}")
    if amg is not None and not isinstance(amg, dict):
        raise ValueError(f"amg: expected a dict of options, got {type(amg).__name__}")
    if isinstance(omega, bool) or not isinstance(omega, numbers.Real) or not (0.0 < omega < 2.0):
        raise ValueError(f"omega: SSOR's relaxation must lie in (0, 2), got {omega!r}")
    systems = _bench_systems(matrices)
    names = [name for name, *_ in systems]
    if len(set(names)) != len(names):
        raise ValueError(f"matrices: a system name is used twice in {names}")

    rows = []
    for name, A, b, nodes in systems:
        try:
            system = _system(A, name=f"matrices[{name!r}]", **nodes)
            n = system.n
            b = (
                np.asarray(A @ np.ones(n), dtype=np.float64).reshape(-1)
                if b is None
                else _vector(b, f"matrices[{name!r}] b", n)
            )
        except ValueError as e:
            where = f"matrices[{name!r}]"
            status = str(e) if str(e).startswith(where) else f"{where}: {e}"
            rows.append(dict.fromkeys(BENCH_COLUMNS) | {"system": name, "status": status})
            continue
        nnz = int(A.nnz)
        best = {}
        for _ in range(repeat):
            for p in preconds:
                if isinstance(best.get(p), str):
                    continue  # failed in an earlier round
                options = {}
                if p == "amg":
                    options = dict(amg=amg)
                elif p == "ssor":
                    options = dict(omega=omega)
                try:
                    P = _CLASSES[p](A, **nodes, **options)
                    _, info = _pcg(P, b, rtol, maxiter, None, None, P.setup_seconds)
                    converged = True
                except ValueError as e:
                    # A bad option is the caller's (raised); a preconditioner
                    # that does not apply to this system (MIC(0) on CSR
                    # storage) is a row, as in ``hookean bench``.
                    if str(e).startswith(("amg:", "omega:")):
                        raise
                    best[p] = f"failed: {e}"
                    continue
                except ConvergenceError as e:
                    info = getattr(e, "info", None)
                    if info is None:  # the set-up broke down
                        best[p] = f"failed: {e}"
                        continue
                    converged = False
                prev = best.get(p)
                if prev is not None:
                    info.setup_seconds = min(info.setup_seconds, prev[0].setup_seconds)
                    info.solve_seconds = min(info.solve_seconds, prev[0].solve_seconds)
                best[p] = (info, converged)
        for p in preconds:
            r = best[p]
            row = dict.fromkeys(BENCH_COLUMNS) | {
                "system": name,
                "rows": n,
                "nonzeros": nnz,
                "block_size": system.block_size,
                "block_size_source": system.block_size_source,
                "preconditioner": p,
            }
            if isinstance(r, str):
                row["status"] = r
            else:
                info, converged = r
                history = info.residual_history
                row |= {
                    "iterations": info.iterations,
                    "setup_s": info.setup_seconds,
                    "solve_s": info.solve_seconds,
                    "total_s": info.setup_seconds + info.solve_seconds,
                    "rel_residual": info.relative_residual,
                    "recursive_rel_residual": history[-1] if history else None,
                    "status": "converged"
                    if converged
                    else f"not converged (|r|/|b| = {info.relative_residual:.1e})",
                }
            rows.append(row)
    try:
        import pandas
    except ImportError:
        return rows
    return pandas.DataFrame(rows, columns=list(BENCH_COLUMNS))
