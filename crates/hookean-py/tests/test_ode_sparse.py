"""hookean.ode.solve_ivp with a sparse Jacobian (SciPy's sparse `jac` and
`jac_sparsity`): the sparse LU path against the dense one and against SciPy,
the column groups of the difference quotients, and the refusals."""

import numpy as np
import pytest
import scipy.integrate
import scipy.sparse as sp
import scipy.sparse.linalg

import hookean.ode as ho
from hookean.ode import _column_groups, _pattern

N = 120


def heat(n=N):
    """Stiff 1D diffusion with a cubic reaction, y' = D y - y^3 (D the
    second-difference operator times n^2, Dirichlet ends): eigenvalues to
    -4 n^2, a stiff system with a tridiagonal Jacobian."""
    D = sp.diags([1.0, -2.0, 1.0], [-1, 0, 1], shape=(n, n), format="csr") * n**2

    def fun(t, y):
        return D @ y - y**3

    def jac(t, y):
        return (D - sp.diags(3.0 * y**2)).tocsr()

    y0 = np.sin(np.pi * np.linspace(0, 1, n + 2)[1:-1]) + 0.5 * np.sin(7 * np.pi * np.linspace(0, 1, n + 2)[1:-1])
    return fun, jac, y0, D


def test_sparse_jac_agrees_with_the_dense_one_and_with_scipy():
    fun, jac, y0, _ = heat()
    t_eval = np.linspace(0.0, 0.05, 6)
    kw = dict(method="BDF", rtol=1e-8, atol=1e-10, t_eval=t_eval)
    sparse = ho.solve_ivp(fun, (0.0, 0.05), y0, jac=jac, **kw)
    dense = ho.solve_ivp(fun, (0.0, 0.05), y0, jac=lambda t, y: jac(t, y).toarray(), **kw)
    scipy_ = scipy.integrate.solve_ivp(fun, (0.0, 0.05), y0, jac=jac, **kw)
    assert sparse.success and dense.success and scipy_.success
    # The same Newton matrices factored two ways: the same steps to round-off.
    assert np.max(np.abs(sparse.y - dense.y)) < 1e-9
    # The same Jacobian evaluations (each with the first, which told its format).
    assert sparse.njev == dense.njev
    # And SciPy's BDF at the same tolerances, to the tolerance's scale.
    assert np.max(np.abs(sparse.y - scipy_.y)) < 1e-5
    # The solution decays (diffusion): an independent sanity bound.
    assert np.abs(sparse.y[:, -1]).max() < np.abs(y0).max()


def test_jac_sparsity_differences_agree_with_the_analytic_jacobian():
    fun, jac, y0, D = heat()
    t_eval = np.linspace(0.0, 0.05, 6)
    kw = dict(method="BDF", rtol=1e-7, atol=1e-10, t_eval=t_eval)
    fd = ho.solve_ivp(fun, (0.0, 0.05), y0, jac_sparsity=D != 0, **kw)
    exact = ho.solve_ivp(fun, (0.0, 0.05), y0, jac=jac, **kw)
    assert fd.success and exact.success
    assert np.max(np.abs(fd.y - exact.y)) < 1e-6
    # Each difference-quotient Jacobian costs 1 + 3 calls of fun (3 groups of a
    # tridiagonal pattern), counted in nfev as SciPy does.
    assert fd.nfev >= fd.njev * 4


def test_column_groups_share_no_row():
    rng = np.random.default_rng(5)
    S = sp.random(80, 80, density=0.05, random_state=rng, format="csr")
    indptr, indices = _pattern(S, 80, "S")
    group, groups = _column_groups(indptr, indices, 80)
    P = sp.csr_array((np.ones(indices.size), indices, indptr), shape=(80, 80)).toarray() != 0
    for g in range(groups):
        cols = np.flatnonzero(group == g)
        # No row has two nonzeros among the group's columns.
        assert P[:, cols].sum(axis=1).max() <= 1
    # Tridiagonal: exactly 3 groups (columns j, j+3, j+6, ... share no row).
    T = sp.diags([1.0, 1.0, 1.0], [-1, 0, 1], shape=(30, 30), format="csr")
    assert _column_groups(*_pattern(T, 30, "T"), 30)[1] == 3


def test_a_constant_sparse_jacobian():
    # y' = -A y, A a tridiagonal SPD matrix: y(t) = expm(-A t) y0.
    A = sp.diags([-1.0, 2.5, -1.0], [-1, 0, 1], shape=(40, 40), format="csc") * 50.0
    y0 = np.linspace(1.0, 2.0, 40)
    r = ho.solve_ivp(lambda t, y: -(A @ y), (0.0, 0.1), y0, jac=-A, rtol=1e-9, atol=1e-12, t_eval=[0.1])
    exact = scipy.sparse.linalg.expm_multiply(-A * 0.1, y0)
    assert r.success and np.max(np.abs(r.y[:, -1] - exact)) < 1e-6


def test_a_sparse_jac_that_leaves_its_pattern_is_refused():
    fun, jac, y0, D = heat(20)
    calls = []

    def wandering(t, y):
        calls.append(t)
        J = jac(t, y).tolil()
        if len(calls) > 1:
            J[0, 19] = 1.0  # outside the first result's pattern
        return J.tocsr()

    with pytest.raises(ValueError, match=r"^jac: returned a nonzero at \(0, 19\)"):
        ho.solve_ivp(fun, (0.0, 0.05), y0, jac=wandering)


def test_a_sparse_jac_that_turns_dense_is_refused():
    fun, jac, y0, D = heat(20)
    calls = []

    def turning(t, y):
        calls.append(t)
        return jac(t, y) if len(calls) == 1 else jac(t, y).toarray()

    with pytest.raises(ValueError, match="^jac: returned a dense array"):
        ho.solve_ivp(fun, (0.0, 0.05), y0, jac=turning)


def test_jac_sparsity_of_the_wrong_shape_is_refused():
    fun, jac, y0, D = heat(20)
    with pytest.raises(ValueError, match="^jac_sparsity: has shape"):
        ho.solve_ivp(fun, (0.0, 0.05), y0, jac_sparsity=np.ones((3, 3)))


def test_a_sparse_jac_of_the_wrong_shape_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"^jac: has shape \(4, 4\), expected \(3, 3\)"):
        ho.solve_ivp(lambda t, y: -y, (0.0, 1.0), np.ones(3), jac=lambda t, y: sp.eye(4, format="csr"))
