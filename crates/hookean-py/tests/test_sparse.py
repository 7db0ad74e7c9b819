"""hookean.sparse on pyamg's gallery systems: answers checked in NumPy,
SciPy's CG with Hookean's AMG, the same results as the `hookean` command."""

import json
import subprocess

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla

import hookean
import hookean.sparse as hs
from conftest import example_bin, hookean_bin as _hookean_bin, poisson_3d, relative_residual


@pytest.mark.parametrize("rtol", [1e-6, 1e-10])
def test_amg_solve_meets_the_tolerance(system, rtol):
    name, A, B, b = system
    x, info = hs.solve(A, b, rtol=rtol, nullspace=B)
    assert info.converged
    assert relative_residual(A, x, b) <= rtol
    assert info.levels >= 2 and 1.0 < info.operator_complexity < 3.0
    assert len(info.residual_history) == info.iterations + 1
    assert info.residual_history[0] == 1.0
    assert info.setup_seconds > 0 and info.solve_seconds > 0


@pytest.mark.parametrize("precond", ["none", "jacobi", "block-jacobi", "ssor", "ic0", "amg"])
def test_every_preconditioner_solves_poisson(precond):
    A, _ = poisson_3d(9)  # 729 unknowns, scalar: block-jacobi's 1x1 blocks
    b = np.random.default_rng(3).standard_normal(A.shape[0])
    x, info = hs.solve(A, b, precond=precond, rtol=1e-9)
    assert info.precond == precond
    assert relative_residual(A, x, b) <= 1e-9


@pytest.mark.parametrize("block_size", [1, 2])
def test_block_jacobi_inverts_the_blocks_of_its_nodes(block_size):
    """2D elasticity (2 unknowns per node, from the pattern; 1 by the flag):
    M^-1 r is the solve with each node's block, in NumPy."""
    from conftest import elasticity_2d

    A, _ = elasticity_2d(6)
    A = A.tocsr()
    n = A.shape[0]
    P = hs.BlockJacobi(A, block_size=None if block_size == 2 else block_size)
    assert (P.block_size, P.format) == (block_size, "csr")
    r = np.random.default_rng(5).standard_normal(n)
    z = P.apply(r)
    D = A.toarray()
    for o in range(0, n, block_size):
        blk = D[o : o + block_size, o : o + block_size]
        np.testing.assert_allclose(z[o : o + block_size], np.linalg.solve(blk, r[o : o + block_size]), rtol=1e-12)
    x, info = P.solve(A @ np.ones(n), rtol=1e-8)
    assert info.converged and relative_residual(A, x, A @ np.ones(n)) <= 1e-8


def test_mic0_on_block_storage():
    from conftest import elasticity_3d

    A, B = elasticity_3d(4)
    b = np.ones(A.shape[0])
    x, info = hs.solve(A, b, precond="mic0", rtol=1e-8)
    assert info.format == "sym-block-3x3"
    assert relative_residual(A, x, b) <= 1e-8


def test_scipy_cg_with_hookean_amg_takes_hookeans_iterations(system):
    """cg(A, b, M=AMG(A).aslinearoperator()) converges within 2 iterations of
    Hookean's own PCG with the same multigrid."""
    name, A, B, b = system
    _, info = hs.solve(A, b, rtol=1e-8, nullspace=B)
    count = [0]

    def tick(xk):
        count[0] += 1

    M = hs.AMG(A, nullspace=B).aslinearoperator()
    x, status = sla.cg(A, b, M=M, rtol=1e-8, maxiter=1000, callback=tick)
    assert status == 0
    assert relative_residual(A, x, b) <= 1e-8 * 1.0001
    assert abs(count[0] - info.iterations) <= 2, (name, count[0], info.iterations)


@pytest.mark.parametrize("fmt", ["csr", "csc", "coo", "bsr", "dok", "lil"])
@pytest.mark.parametrize("index", [np.int32, np.int64])
def test_every_format_gives_the_same_bits(fmt, index):
    A, _ = poisson_3d(8)
    b = np.arange(A.shape[0], dtype=float) % 7 - 3
    x_ref, _ = hs.solve(A.tocsr(), b)
    M = A.asformat(fmt)
    if fmt in ("csr", "csc", "bsr"):
        M.indices = M.indices.astype(index)
        M.indptr = M.indptr.astype(index)
    elif fmt == "coo":
        M.row, M.col = M.row.astype(index), M.col.astype(index)
    x, _ = hs.solve(M, b)
    assert np.array_equal(x, x_ref)


def test_sparse_arrays_and_float32():
    A, _ = poisson_3d(8)
    b = np.ones(A.shape[0])
    x, _ = hs.solve(sp.csr_array(A), b)
    assert relative_residual(A, x, b) <= 1e-8
    A32 = A.astype(np.float32)
    x, _ = hs.solve(A32, b.astype(np.float32))
    # float32 entries are the matrix solved (exactly representable here).
    assert relative_residual(A32.astype(np.float64), x, b) <= 1e-8


def test_unsorted_and_duplicate_entries_are_summed():
    A, _ = poisson_3d(6)
    C = A.tocoo()
    # Each entry split into two halves, in reverse order.
    row = np.concatenate([C.row, C.row])[::-1]
    col = np.concatenate([C.col, C.col])[::-1]
    val = np.concatenate([C.data / 2, C.data / 2])[::-1]
    D = sp.coo_matrix((val, (row, col)), shape=A.shape)
    b = np.ones(A.shape[0])
    x, _ = hs.solve(D, b)
    assert relative_residual(A, x, b) <= 1e-8


def test_refill_takes_the_new_values():
    A, _ = poisson_3d(9)
    b = np.random.default_rng(1).standard_normal(A.shape[0])
    for P in (hs.AMG(A), hs.IC0(A), hs.SSOR(A, omega=1.2), hs.Jacobi(A), hs.BlockJacobi(A)):
        A2 = A.copy()
        A2.data = A2.data * 3.0
        A2.setdiag(A2.diagonal() + 1.0)
        P.refill(A2)
        x, info = P.solve(b, rtol=1e-9)
        assert relative_residual(A2, x, b) <= 1e-9, P.name
        # The old matrix's solution is not this one.
        assert relative_residual(A, x, b) > 1e-3


def test_preconditioner_is_symmetric_positive_definite(system):
    """M^-1 of AMG: r . M^-1 s = s . M^-1 r and r . M^-1 r > 0."""
    name, A, B, b = system
    P = hs.AMG(A, nullspace=B)
    rng = np.random.default_rng(5)
    r, s = rng.standard_normal((2, A.shape[0]))
    Mr, Ms = P.apply(r), P.apply(s)
    assert abs(r @ Ms - s @ Mr) <= 1e-5 * np.linalg.norm(r) * np.linalg.norm(Ms)
    assert r @ Mr > 0


def test_a_built_preconditioner_is_reused_without_setup():
    A, _ = poisson_3d(8)
    P = hs.AMG(A)
    b = np.ones(A.shape[0])
    x, info = hs.solve(A, b, precond=P)
    assert info.setup_seconds == 0.0
    assert relative_residual(A, x, b) <= 1e-8


def test_callback_sees_each_iterate_and_x0_warm_starts():
    A, _ = poisson_3d(8)
    b = np.ones(A.shape[0])
    seen = []
    x, info = hs.solve(A, b, precond="ic0", callback=lambda xk: seen.append(relative_residual(A, xk, b)))
    assert len(seen) == info.iterations
    # The iterates it saw approach the solution PCG returned.
    assert seen[0] > 1e3 * seen[-1] and relative_residual(A, x, b) <= 1e-8
    _, warm = hs.solve(A, b, precond="ic0", x0=x)
    assert warm.iterations == 0


def test_maxiter_reached_raises_convergence_error_with_the_iterate():
    A, _ = poisson_3d(10)
    b = np.ones(A.shape[0])
    with pytest.raises(hookean.ConvergenceError, match="did not reach rtol") as e:
        hs.solve(A, b, precond="jacobi", maxiter=3)
    assert isinstance(e.value, RuntimeError)
    assert e.value.info.iterations == 3 and e.value.x.shape == b.shape


def test_an_indefinite_matrix_raises_convergence_error():
    A = sp.diags([1.0] * 10 + [-1.0] * 10, format="csr")
    with pytest.raises(hookean.ConvergenceError):
        hs.solve(A, np.ones(20), precond="none")


@pytest.mark.skipif(_hookean_bin() is None, reason="no `hookean` binary (cargo build -p hookean-cli, or HOOKEAN_BIN)")
@pytest.mark.parametrize("precond", ["amg", "ic0", "ssor"])
def test_same_results_as_hookean_solve(system, precond, tmp_path):
    """The same iterations and residual as `hookean solve` on the system
    written as Matrix Market (the Rust API's path)."""
    name, A, B, b = system
    scipy.io.mmwrite(tmp_path / "A.mtx", sp.coo_matrix(A), precision=17)
    scipy.io.mmwrite(tmp_path / "b.mtx", b[:, None], precision=17)
    args = [_hookean_bin(), "solve", str(tmp_path / "A.mtx"), "--rhs", str(tmp_path / "b.mtx"),
            "--precond", precond, "--rtol", "1e-8"]
    if B is not None:
        scipy.io.mmwrite(tmp_path / "B.mtx", B, precision=17)
        args += ["--nullspace", str(tmp_path / "B.mtx")]
    out = subprocess.run(args, capture_output=True, text=True, check=True).stdout
    cli = json.loads(out.splitlines()[0])
    x, info = hs.solve(A, b, precond=precond, rtol=1e-8, nullspace=B)
    assert info.iterations == cli["iterations"]
    assert info.format == cli["format"] and info.block_size == cli["block_size"]
    # Both are PCG's true residual of the same iterate (the command's is on
    # A scaled by a power of two: exact), to round-off of the residual's sum.
    assert relative_residual(A, x, b) == pytest.approx(cli["rel_residual"], rel=1e-6)


def test_solves_in_a_thread_pool_give_the_sequential_bits():
    """Set-ups and solves run without the GIL, several at once: each gives
    the bits it gives alone."""
    from concurrent.futures import ThreadPoolExecutor

    from conftest import elasticity_2d

    A, B = elasticity_2d(16)
    rhs = [np.random.default_rng(s).standard_normal(A.shape[0]) for s in range(4)]
    alone = [hs.solve(A, b, nullspace=B)[0] for b in rhs]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(lambda b: hs.solve(A, b, nullspace=B)[0], rhs))
    for x, y in zip(alone, together):
        assert np.array_equal(x, y)


def test_solve_info_pickles():
    import pickle

    A, _ = poisson_3d(6)
    _, info = hs.solve(A, np.ones(A.shape[0]))
    assert pickle.loads(pickle.dumps(info)) == info


def test_the_gil_is_released_during_a_solve():
    """While PCG runs in a thread, the main thread keeps running: its
    longest pause is a fraction of the solve (holding the GIL, it would be
    the whole solve)."""
    import threading
    import time

    A, _ = poisson_3d(40)
    b = np.ones(A.shape[0])
    P = hs.Jacobi(A)
    span = {}

    def work():
        span["start"] = time.perf_counter()
        P.solve(b, rtol=1e-12)
        span["end"] = time.perf_counter()

    worker = threading.Thread(target=work)
    stamps = []
    worker.start()
    while worker.is_alive():
        stamps.append(time.perf_counter())
    worker.join()
    inside = [t for t in stamps if span["start"] <= t <= span["end"]]
    edges = [span["start"]] + inside + [span["end"]]
    longest = max(b - a for a, b in zip(edges, edges[1:]))
    assert longest < 0.5 * (span["end"] - span["start"]), (longest, span)


def _pcg_solution_bin():
    return example_bin("pcg_solution", "HOOKEAN_PCG_SOLUTION_BIN")


@pytest.mark.skipif(
    _pcg_solution_bin() is None,
    reason="no pcg_solution example (cargo build -p hookean-sparse --example pcg_solution)",
)
@pytest.mark.parametrize("precond", ["amg", "ic0", "jacobi"])
def test_same_bits_as_the_rust_api(system, precond, tmp_path):
    """x bit for bit as crates/hookean-sparse/examples/pcg_solution.rs, the
    library's PCG called from Rust on the system written as Matrix Market."""
    name, A, B, b = system
    scipy.io.mmwrite(tmp_path / "A.mtx", sp.coo_matrix(A), precision=17)
    scipy.io.mmwrite(tmp_path / "b.mtx", b[:, None], precision=17)
    args = [_pcg_solution_bin(), str(tmp_path / "A.mtx"), str(tmp_path / "b.mtx"), precond]
    if B is not None:
        scipy.io.mmwrite(tmp_path / "B.mtx", B, precision=17)
        args.append(str(tmp_path / "B.mtx"))
    out = subprocess.run(args, capture_output=True, text=True, check=True).stdout
    rust = np.array([float(v) for v in out.split()])
    x, _ = hs.solve(A, b, precond=precond, rtol=1e-8, nullspace=B)
    assert x.shape == rust.shape
    assert np.array_equal(x.view(np.uint64), rust.view(np.uint64))
