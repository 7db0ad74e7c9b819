"""Every bad input raises ValueError naming the argument: no crash, no
PanicException (pyo3_runtime.PanicException derives from BaseException, so
`pytest.raises(ValueError)` would not catch one and the test would fail)."""

import numpy as np
import pytest
import scipy.sparse as sp

import hookean.sparse as hs
from conftest import elasticity_2d, poisson_3d

A, _ = poisson_3d(6)
N = A.shape[0]
b = np.ones(N)


def check(match, *args, **kwargs):
    with pytest.raises(ValueError, match=match):
        hs.solve(*args, **kwargs)


def test_dense_matrix():
    check("^A: expected a scipy.sparse", A.toarray(), b)


def test_non_square():
    check(r"^A: the matrix is not square \(216 x 215\)", A[:, :-1], b)


def test_nonsymmetric():
    B = A.tolil()
    B[0, 1] = 5.0
    check("^A: .*not symmetric.*PCG needs a symmetric matrix", B.tocsr(), b)


def test_complex_and_integer_matrices():
    check("^A: expected float64 or float32 entries, got complex128", A.astype(complex), b)
    check("^A: expected float64 or float32 entries, got int64", A.astype(np.int64), b)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_matrix_entry(bad):
    B = A.copy()
    B.data[3] = bad
    check("^A: entry 3 of its data is", B, b)


def test_empty_matrix():
    check(r"^A: the matrix is empty \(0 x 0\)", sp.csr_matrix((0, 0)), np.ones(0))


def test_right_hand_side_shape_and_values():
    check(r"^b: expected shape \(216,\), got \(215,\)", A, b[:-1])
    check(r"^b: expected shape \(216,\), got \(216, 2\)", A, np.ones((N, 2)))
    check("^b: expected real numbers", A, np.array(["x"] * N))
    check("^b: expected real numbers", A, b.astype(complex))
    c = b.copy()
    c[5] = np.nan
    check("^b: entry 5 is NaN", A, c)


def test_x0_shape_and_values():
    check(r"^x0: expected shape \(216,\)", A, b, x0=np.ones(3))
    check("^x0: entry 0 is inf", A, b, x0=np.full(N, np.inf))


@pytest.mark.parametrize("rtol", [-1e-8, 1.0, np.nan, 2])
def test_tolerance_out_of_range(rtol):
    check(r"^rtol: must lie in \[0, 1\)", A, b, rtol=rtol)


def test_tolerance_not_a_number():
    check("^rtol: expected a number", A, b, rtol="small")


@pytest.mark.parametrize("maxiter", [-1, 10**8, 2.5, "10"])
def test_maxiter(maxiter):
    check("^maxiter: ", A, b, maxiter=maxiter)


@pytest.mark.parametrize("name", ["ilu", "AMG", "", None, 3])
def test_unknown_preconditioner_name(name):
    check("^precond: unknown preconditioner", A, b, precond=name)


def test_mic0_on_scalar_storage():
    # 125 unknowns: no 3x3 blocks.
    check("^precond: mic0 needs 3x3 block storage", poisson_3d(5)[0], np.ones(125), precond="mic0")


@pytest.mark.parametrize("block_size", [0, 4, -1, 2.0, True])
def test_block_size(block_size):
    check("^block_size: must be 1, 2 or 3", A, b, block_size=block_size)


def test_nullspace_shapes():
    E, B = elasticity_2d(6)
    e = np.ones(E.shape[0])
    check("^nullspace: has 10 rows", E, e, nullspace=B[:10])
    check("^nullspace: column 1 is zero", E, e, nullspace=np.c_[B[:, 0], 0 * B[:, 1]])
    check("^nullspace: has a NaN", E, e, nullspace=np.full_like(B, np.nan))
    check("^nullspace: 4 vectors on nodes of 2 unknowns", E, e, nullspace=np.c_[B, B[:, :1]])
    check("^nullspace: give nullspace or coordinates, not both", E, e, nullspace=B, coordinates=np.zeros((E.shape[0] // 2, 2)))
    check("^nullspace: expected a 2D array", E, e, nullspace=np.ones((2, 2, 2)))


def test_coordinates_shape():
    E, _ = elasticity_2d(6)
    check(r"^coordinates: has shape \(3, 2\)", E, np.ones(E.shape[0]), coordinates=np.zeros((3, 2)))
    check(r"^coordinates: has shape", E, np.ones(E.shape[0]), coordinates=np.zeros((E.shape[0], 1)))


def test_amg_options():
    check("^amg: unknown option 'levels'", A, b, amg={"levels": 3})
    check("^amg: 'sweeps' must be a non-negative integer", A, b, amg={"sweeps": -1})
    check("^amg: 'smoother' must be block-jacobi", A, b, amg={"smoother": "chebyshev"})
    check("^amg: .*", A, b, amg={"jacobi_weight": 5.0})
    check("^amg: expected a dict", A, b, amg=[("sweeps", 2)])
    check("^amg: multigrid options given with precond='ic0'", A, b, precond="ic0", amg={"sweeps": 2})


def test_ssor_relaxation():
    with pytest.raises(ValueError, match="^precond: .*omega"):
        hs.SSOR(A, omega=2.5)


def test_refill_with_another_pattern_or_size():
    P = hs.IC0(A)
    with pytest.raises(ValueError, match="^A: refill needs the sparsity pattern"):
        P.refill(A + sp.eye(N, k=3) + sp.eye(N, k=-3))
    with pytest.raises(ValueError, match="^A: refill needs the sparsity pattern"):
        P.refill(poisson_3d(5)[0])


def test_apply_wrong_length():
    with pytest.raises(ValueError, match=r"^r: expected shape \(216,\)"):
        hs.Jacobi(A).apply(np.ones(5))


def test_prebuilt_preconditioner_of_another_size():
    with pytest.raises(ValueError, match="^precond: built for shape"):
        hs.solve(poisson_3d(5)[0], np.ones(125), precond=hs.Jacobi(A))


def test_callback_not_callable_and_callback_raising():
    check("^callback: expected a callable", A, b, callback=3)

    class Stop(Exception):
        pass

    def cb(xk):
        raise Stop("from the callback")

    with pytest.raises(Stop, match="from the callback"):
        hs.solve(A, b, callback=cb)


@pytest.mark.parametrize("index", [np.int32, np.int64])
def test_index_outside_the_matrix_names_the_entry(index):
    M = A.tocsr().copy()
    M.indices = M.indices.astype(index)
    M.indptr = M.indptr.astype(index)
    M.indices[5] = -1
    with pytest.raises(ValueError, match="^A: column index entry -1 outside 0 to"):
        hs.solve(M, np.ones(N))
    M.indices[5] = N
    with pytest.raises(ValueError, match=f"^A: column index entry {N} outside 0 to {N - 1}"):
        hs.solve(M, np.ones(N))


def test_asymmetric_matrix_names_the_entry_on_either_storage():
    # Scalar (CSR) and 3x3-block storage check symmetry as they convert.
    for block_size in (1, 3):
        M = (A + sp.eye(N, k=1, format="csr") * 1e-3).tocsr()
        with pytest.raises(ValueError, match=r"^A: .*\(PCG needs a symmetric matrix\)"):
            hs.solve(M, np.ones(N), block_size=block_size, precond="jacobi")
