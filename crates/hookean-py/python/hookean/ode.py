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


def _jac(jac, n):
    """``jac`` as a callable returning a C-contiguous (n, n) float array
    (a constant matrix, a dense or a scipy.sparse result densified), or
    None for the BDF's difference-quotient Jacobian."""
    if jac is None:
        return None

    def dense(j):
        if scipy.sparse.issparse(j):
            j = j.toarray()
        j = np.ascontiguousarray(j, dtype=float)
        if j.shape != (n, n):
            raise ValueError(f"jac: returned shape {j.shape}, expected ({n}, {n})")
        return j

    if callable(jac):
        return lambda t, y: dense(jac(t, y))
    constant = dense(jac)
    if not np.all(np.isfinite(constant)):
        raise ValueError("jac: has NaN or infinite entries")
    return lambda t, y: constant


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
    ``jac_sparsity`` is checked for its shape and otherwise unused (the
    Newton matrix is dense); ``first_step`` and ``max_step`` positive.
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
    r = _hookean.bdf_solve(
        _returns_floats(fun),
        _jac(jac, n),
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
        nfev=r["nfev"],
        njev=r["njev"],
        nlu=r["nlu"],
        status=status,
        message=MESSAGES.get(status, r["message"]),
        success=status >= 0,
        stats={
            k: r[k] for k in ("steps", "rejected_steps", "newton_iterations", "event_evaluations")
        },
    )
