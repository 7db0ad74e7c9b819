"""Stiff initial value problems on Hookean's variable-order BDF, with
SciPy's interface: ``hookean.ode.solve_ivp`` takes the arguments of
``scipy.integrate.solve_ivp(method="BDF")`` and returns its result fields,
so that porting a script is one changed import::

    from hookean.ode import solve_ivp        # was: from scipy.integrate import solve_ivp

``fun(t, y)``, ``jac(t, y)`` and the events are the caller's Python
callables; an exception raised in one of them propagates unchanged. Bad
arguments raise ``ValueError`` naming the argument. As SciPy's, a run that
fails on valid input returns ``status = -1``, ``success = False`` and the
reason in ``message`` (with the solution up to the failure).
"""

import math
import numbers

import numpy as np
import scipy.sparse
from scipy.integrate import DenseOutput, OdeSolution
from scipy.optimize import OptimizeResult

from . import _hookean

__all__ = ["solve_ivp", "OdeResult"]

MESSAGES = {
    0: "The solver successfully reached the end of the integration interval.",
    1: "A termination event occurred.",
}


class OdeResult(OptimizeResult):
    """The result of :func:`solve_ivp`: SciPy's fields ``t``, ``y``,
    ``sol``, ``t_events``, ``y_events``, ``nfev``, ``njev``, ``nlu``,
    ``status``, ``message``, ``success``, and Hookean's counters in
    ``stats`` (steps, rejected steps, Newton iterations, event
    evaluations)."""


class StepPolynomial(DenseOutput):
    """The BDF's interpolating polynomial on one step ``[t_old, t]``, given
    by its values at six Chebyshev-Lobatto nodes and evaluated in
    barycentric form (the interpolant has the step's order, at most 5, so
    the six values determine it)."""

    def __init__(self, t_old, t, nodes_t, nodes_y):
        super().__init__(t_old, t)
        self.nodes_t = nodes_t
        self.nodes_y = nodes_y  # (6, n)
        w = np.array([(-1.0) ** j for j in range(len(nodes_t))])
        w[0] *= 0.5
        w[-1] *= 0.5
        self.weights = w

    def _call_impl(self, t):
        scalar = np.ndim(t) == 0
        t = np.atleast_1d(np.asarray(t, dtype=float))
        d = t[:, None] - self.nodes_t[None, :]
        exact = d == 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            c = self.weights[None, :] / d
        hit = exact.any(axis=1)
        c[hit] = exact[hit].astype(float)
        p = (c @ self.nodes_y) / c.sum(axis=1)[:, None]
        return p[0] if scalar else p.T


def _float(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a number, got {value!r}") from None
    return v


def _returns_floats(f):
    """``fun`` returning a float array (SciPy's ``np.asarray``), with a
    result that is not one reported as bad input naming ``fun``."""

    def call(t, y):
        v = f(t, y)
        try:
            return np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"fun: must return an array of floats, got {v!r:.40}") from None

    return call


def _events(events):
    if events is None:
        return [], [], []
    if callable(events):
        events = [events]
    fns, directions, terminal = [], [], []
    for i, e in enumerate(events):
        if not callable(e):
            raise ValueError(f"events: entry {i} is not callable")
        term = getattr(e, "terminal", False)
        if isinstance(term, numbers.Integral) and not isinstance(term, bool):
            if term < 0:
                raise ValueError(f"events: entry {i}: terminal must be a bool or non-negative")
            if term > 1:
                raise ValueError(
                    f"events: entry {i}: terminal = {term} (a count of occurrences) is not "
                    "supported; use True to stop at the first"
                )
        direction = _float(f"events: entry {i}: direction", getattr(e, "direction", 0.0))
        fns.append(lambda t, y, e=e: float(e(t, y)))
        directions.append(int(np.sign(direction)))
        terminal.append(bool(term))
    return fns, directions, terminal


#: The relative step of the difference quotients on ``jac_sparsity`` (the
#: square root of the unit round-off, the usual forward-difference choice).
_FD_STEP = math.sqrt(np.finfo(float).eps)


def _pattern(S, n, name):
    """The CSR pattern of ``S`` (sparse or dense) with the diagonal added, canonical."""
    S = scipy.sparse.csr_array(S)
    if S.shape != (n, n):
        raise ValueError(f"{name}: has shape {S.shape}, expected ({n}, {n})")
    S = scipy.sparse.csr_array(S.astype(bool).astype(float) + scipy.sparse.eye_array(n, format="csr"))
    S.sum_duplicates()
    S.sort_indices()
    return np.asarray(S.indptr, dtype=np.int64), np.asarray(S.indices, dtype=np.int64)


def _on_pattern(J, indptr, indices, n):
    """The values of the sparse ``J`` in the CSR order of ``(indptr, indices)``."""
    J = scipy.sparse.coo_array(J)
    if J.shape != (n, n):
        raise ValueError(f"jac: returned shape {J.shape}, expected ({n}, {n})")
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
    keys = rows * n + indices  # increasing: the pattern is canonical
    k = J.row.astype(np.int64) * n + J.col.astype(np.int64)
    pos = np.searchsorted(keys, k)
    inside = (pos < keys.size) & (keys[np.minimum(pos, keys.size - 1)] == k)
    if not np.all(inside | (J.data == 0.0)):
        i = int(np.flatnonzero(~inside & (J.data != 0.0))[0])
        raise ValueError(
            f"jac: returned a nonzero at ({J.row[i]}, {J.col[i]}), outside the pattern of "
            "its first result (a sparse jac must keep its sparsity pattern)"
        )
    values = np.zeros(keys.size)
    np.add.at(values, pos[inside], J.data[inside])
    return values


def _column_groups(indptr, indices, n):
    """Columns that share no row, in groups (Curtis, Powell and Reid, 1974):
    one difference quotient of ``fun`` gives all the columns of a group.
    Greedy, in column order."""
    csc = scipy.sparse.csr_array((np.ones(indices.size), indices, indptr), shape=(n, n)).tocsc()
    group = np.empty(n, dtype=np.int64)
    taken = []  # per group, the rows its columns touch
    for j in range(n):
        rows = csc.indices[csc.indptr[j]:csc.indptr[j + 1]]
        for g, mask in enumerate(taken):
            if not mask[rows].any():
                break
        else:
            g = len(taken)
            taken.append(np.zeros(n, dtype=bool))
        taken[g][rows] = True
        group[j] = g
    return group, len(taken)


def _sparse_differences(fun, indptr, indices, n, counts):
    """``jac(t, y)`` by forward differences of ``fun`` on the pattern, one
    evaluation per column group, returning the values in the pattern's order."""
    group, groups = _column_groups(indptr, indices, n)
    rows = np.repeat(np.arange(n), np.diff(indptr))

    def jac(t, y):
        f0 = np.asarray(fun(t, y), dtype=float)
        h = _FD_STEP * np.maximum(np.abs(y), 1.0)
        h = (y + h) - y  # a step the floating point can represent exactly
        values = np.empty(indices.size)
        for g in range(groups):
            cols = group == g
            step = np.where(cols, h, 0.0)
            df = np.asarray(fun(t, y + step), dtype=float) - f0
            on = cols[indices]
            values[on] = df[rows[on]] / h[indices[on]]
        counts["nfev"] += 1 + groups
        return values

    return jac


def _jac(jac, n, jac_sparsity, fun, t0, y0, counts):
    """``jac`` for the BDF: ``(callable, pattern)``. The callable returns a
    C-contiguous (n, n) float array (``pattern`` None: dense LU), or the
    values of a sparse Jacobian in the CSR order of ``pattern = (indptr,
    indices)`` (sparse LU). As SciPy: a ``jac`` whose first result (at
    ``(t0, y0)``, counted in ``njev``) is sparse keeps that pattern; with
    ``jac`` None, ``jac_sparsity`` makes the difference quotients sparse
    (their ``fun`` calls counted in ``nfev``), without it the BDF takes
    dense ones. ``counts`` takes the ``nfev`` and ``njev`` made here."""
    if jac is None:
        if jac_sparsity is None:
            return None, None
        indptr, indices = _pattern(jac_sparsity, n, "jac_sparsity")
        return _sparse_differences(fun, indptr, indices, n, counts), (indptr, indices)

    def dense(j):
        if scipy.sparse.issparse(j):
            j = j.toarray()
        j = np.ascontiguousarray(j, dtype=float)
        if j.shape != (n, n):
            raise ValueError(f"jac: returned shape {j.shape}, expected ({n}, {n})")
        return j

    if callable(jac):
        first = jac(t0, y0.copy())
        counts["njev"] += 1
        if not scipy.sparse.issparse(first):
            return (lambda t, y: dense(jac(t, y))), None
        indptr, indices = _pattern(first, n, "jac")

        def sparse(t, y):
            j = jac(t, y)
            if not scipy.sparse.issparse(j):
                raise ValueError("jac: returned a dense array after a sparse first result")
            return _on_pattern(j, indptr, indices, n)

        return sparse, (indptr, indices)
    if scipy.sparse.issparse(jac):
        indptr, indices = _pattern(jac, n, "jac")
        values = _on_pattern(jac, indptr, indices, n)
        if not np.all(np.isfinite(values)):
            raise ValueError("jac: has NaN or infinite entries")
        return (lambda t, y: values), (indptr, indices)
    constant = dense(jac)
    if not np.all(np.isfinite(constant)):
        raise ValueError("jac: has NaN or infinite entries")
    return (lambda t, y: constant), None


def solve_ivp(
    fun,
    t_span,
    y0,
    method="BDF",
    t_eval=None,
    dense_output=False,
    events=None,
    vectorized=False,
    args=None,
    rtol=1e-3,
    atol=1e-6,
    jac=None,
    jac_sparsity=None,
    first_step=None,
    max_step=math.inf,
):
    """Solves ``y' = fun(t, y)``, ``y(t_span[0]) = y0`` with Hookean's
    variable-order BDF (orders 1 to 5, hookean-ode's ``Method::VariableBdf``
    with its defaults), with the signature and result of
    ``scipy.integrate.solve_ivp``.

    Parameters are SciPy's: ``method`` must be ``"BDF"``; ``t_span`` an
    increasing pair ``(t0, tf)``; ``t_eval`` increasing times in it (the
    solution is reported there instead of at every step); ``dense_output``
    builds ``sol``, a ``scipy.integrate.OdeSolution`` of the BDF's
    interpolants; ``events`` a callable ``g(t, y)`` or a list of them, with
    optional attributes ``terminal`` (bool) and ``direction`` (sign);
    ``args`` extra arguments of ``fun``, ``jac`` and the events; ``rtol``
    and ``atol`` (scalar or one per component) non-negative; ``jac`` a
    callable ``jac(t, y)`` returning a dense array or a ``scipy.sparse``
    matrix, or a constant matrix, or None for difference quotients;
    ``jac_sparsity`` the Jacobian's sparsity pattern for the difference
    quotients when ``jac`` is None (ignored otherwise, as in SciPy). A sparse
    Jacobian (``jac`` returning or being a ``scipy.sparse`` matrix, or
    ``jac_sparsity``) makes the BDF factor its Newton matrix with a sparse
    LU, as SciPy's ``splu``; a sparse ``jac`` must keep the pattern of its
    first result. ``first_step`` and ``max_step`` positive.
    ``vectorized`` is accepted and ignored (``fun`` is called on one state).

    Returns an :class:`OdeResult` with SciPy's fields. Bad arguments raise
    ``ValueError`` naming the argument; an exception raised by ``fun``,
    ``jac`` or an event propagates unchanged.
    """
    if method != "BDF":
        raise ValueError(f"method: {method!r} is not supported; Hookean's solve_ivp runs 'BDF'")
    if not callable(fun):
        raise ValueError("fun: must be callable")
    try:
        t0, tf = t_span
    except (TypeError, ValueError):
        raise ValueError("t_span: must be a pair (t0, tf)") from None
    t0, tf = _float("t_span", t0), _float("t_span", tf)
    if not (math.isfinite(t0) and math.isfinite(tf)):
        raise ValueError(f"t_span: must be finite, got ({t0}, {tf})")
    if not tf > t0:
        raise ValueError(f"t_span: must be increasing (t0 < tf), got ({t0}, {tf})")
    y0 = np.asarray(y0)
    if np.iscomplexobj(y0):
        raise ValueError("y0: complex values are not supported")
    y0 = np.array(y0, dtype=float)
    if y0.ndim != 1 or y0.size == 0:
        raise ValueError(f"y0: must be a non-empty 1-D array, got shape {y0.shape}")
    if not np.all(np.isfinite(y0)):
        raise ValueError("y0: has NaN or infinite entries")
    n = y0.size
    rtol = _float("rtol", rtol)
    if not (rtol > 0.0 and math.isfinite(rtol)):
        raise ValueError(f"rtol: must be positive and finite, got {rtol}")
    atol = np.array(atol, dtype=float)
    if atol.ndim > 1 or (atol.ndim == 1 and atol.size != n):
        raise ValueError(f"atol: must be a number or one per component ({n}), got shape {atol.shape}")
    if not np.all((atol >= 0.0) & np.isfinite(atol)):
        raise ValueError("atol: must be non-negative and finite")
    atol = list(np.atleast_1d(atol))
    if first_step is not None:
        first_step = _float("first_step", first_step)
        if not (first_step > 0.0 and first_step <= tf - t0):
            raise ValueError(f"first_step: must be positive and at most tf - t0, got {first_step}")
    max_step = _float("max_step", max_step)
    if not max_step > 0.0:
        raise ValueError(f"max_step: must be positive, got {max_step}")
    if t_eval is not None:
        t_eval = np.array(t_eval, dtype=float)
        if t_eval.ndim != 1:
            raise ValueError(f"t_eval: must be 1-D, got shape {t_eval.shape}")
        if t_eval.size and not (t_eval[0] >= t0 and t_eval[-1] <= tf):
            raise ValueError("t_eval: values must lie within t_span")
        if np.any(np.diff(t_eval) <= 0):
            raise ValueError("t_eval: must be strictly increasing")
    if jac_sparsity is not None:
        shape = np.shape(jac_sparsity) if not scipy.sparse.issparse(jac_sparsity) else jac_sparsity.shape
        if tuple(shape) != (n, n):
            raise ValueError(f"jac_sparsity: has shape {tuple(shape)}, expected ({n}, {n})")
        if jac is not None:
            jac_sparsity = None  # SciPy: ignored when jac is given
    if args is not None:
        if not isinstance(args, tuple):
            args = (args,)
        user_fun, user_jac, user_events = fun, jac, events
        fun = lambda t, y: user_fun(t, y, *args)  # noqa: E731
        if callable(user_jac):
            jac = lambda t, y: user_jac(t, y, *args)  # noqa: E731
        if user_events is not None:
            wrapped = []
            for e in [user_events] if callable(user_events) else user_events:
                w = lambda t, y, e=e: e(t, y, *args)  # noqa: E731
                w.terminal = getattr(e, "terminal", False)
                w.direction = getattr(e, "direction", 0.0)
                wrapped.append(w)
            events = wrapped
    event_fns, directions, terminal = _events(events)
    counts = {"nfev": 0, "njev": 0}  # calls made here (SciPy counts them too)
    jac_fn, pattern = _jac(jac, n, jac_sparsity, _returns_floats(fun), t0, y0, counts)
    r = _hookean.bdf_solve(
        _returns_floats(fun),
        jac_fn,
        None if pattern is None else (list(pattern[0]), list(pattern[1])),
        t0,
        list(y0),
        tf,
        rtol,
        atol,
        first_step,
        max_step,
        None if t_eval is None else list(t_eval),
        bool(dense_output),
        event_fns,
        directions,
        terminal,
    )
    t = np.array(r["t"], dtype=float)
    y = np.array(r["y"], dtype=float).reshape(len(t), n).T
    sol = None
    if dense_output:
        seg = np.array(r["segments"], dtype=float)
        nodes = np.array(r["nodes"], dtype=float).reshape(-1, 6, n)
        interpolants = []
        for k in range(len(seg) - 1):
            a, b = seg[k], seg[k + 1]
            s = 0.5 * (1.0 - np.cos(np.pi * np.arange(6) / 5))
            tk = a + (b - a) * s
            tk[-1] = b
            interpolants.append(StepPolynomial(a, b, tk, nodes[k]))
        if interpolants:
            sol = OdeSolution(seg, interpolants)
    m = len(event_fns)
    t_events = [[] for _ in range(m)]
    y_events = [[] for _ in range(m)]
    for i, te, ye in r["events"]:
        t_events[i].append(te)
        y_events[i].append(ye)
    status = r["status"]
    return OdeResult(
        t=t,
        y=y,
        sol=sol,
        t_events=[np.asarray(te) for te in t_events] if events is not None else None,
        y_events=[np.asarray(ye) for ye in y_events] if events is not None else None,
        nfev=r["nfev"] + counts["nfev"],
        njev=r["njev"] + counts["njev"],
        nlu=r["nlu"],
        status=status,
        message=MESSAGES.get(status, r["message"]),
        success=status >= 0,
        stats={
            k: r[k] for k in ("steps", "rejected_steps", "newton_iterations", "event_evaluations")
        },
    )
