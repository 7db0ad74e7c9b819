"""hookean.sparse.bench: the rows of `hookean bench` on the same systems
(iterations, sizes, statuses read from its bench.csv), and its refusals."""

import csv
import subprocess

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import hookean.sparse as hs
from conftest import SYSTEMS, hookean_bin as _hookean_bin


def _rows(result):
    """A DataFrame (pandas importable) or the list of dicts, as a list of dicts."""
    return result.to_dict("records") if hasattr(result, "to_dict") else result


@pytest.mark.skipif(_hookean_bin() is None, reason="no `hookean` binary (cargo build -p hookean-cli, or HOOKEAN_BIN)")
def test_the_rows_of_hookean_bench(tmp_path):
    systems = {}
    folder = tmp_path / "systems"
    folder.mkdir()
    for name in ("elasticity-2d", "poisson-3d"):
        A, B = SYSTEMS[name]()
        systems[name] = {"A": A} if B is None else {"A": A, "nullspace": B}
        scipy.io.mmwrite(folder / f"{name}.mtx", sp.coo_matrix(A), precision=17)
        if B is not None:
            scipy.io.mmwrite(folder / f"{name}_nullspace.mtx", B, precision=17)
    preconds = ["jacobi", "ssor", "ic0", "mic0", "amg"]
    subprocess.run(
        [_hookean_bin(), "bench", str(folder), "--precond", ",".join(preconds), "--repeat", "1",
         "--out", str(tmp_path / "out"), "--quiet"],
        check=True, capture_output=True,
    )
    with open(tmp_path / "out" / "bench.csv", newline="") as f:
        cli = {(r["system"], r["preconditioner"]): r for r in csv.DictReader(f)}
    rows = _rows(hs.bench(systems, preconds=preconds, repeat=1))
    assert set(rows[0]) == set(hs.BENCH_COLUMNS)
    assert {(r["system"], r["preconditioner"]) for r in rows} == set(cli)
    for r in rows:
        c = cli[(r["system"], r["preconditioner"])]
        assert str(r["rows"]) == c["rows"] and str(r["nonzeros"]) == c["nonzeros"]
        assert str(r["block_size"]) == c["block_size"]
        assert r["block_size_source"] == c["block_size_source"]
        assert r["status"].split(":")[0] == c["status"].split(":")[0], (r, c)
        if r["status"] == "converged":
            assert str(r["iterations"]) == c["iterations"]
            assert r["rel_residual"] <= 1e-8
            assert r["total_s"] == pytest.approx(r["setup_s"] + r["solve_s"])
    # MIC(0) needs 3x3 block storage; both systems are CSR (1 and 2 unknowns
    # per node): failed rows, in both tables.
    assert all(r["status"].startswith("failed") for r in rows if r["preconditioner"] == "mic0")


def test_best_of_rounds_and_the_failures_are_rows():
    A = SYSTEMS["poisson-3d"]()[0]
    bad = sp.random(30, 30, density=0.2, random_state=1, format="csr") + sp.eye(30)  # not symmetric
    rows = _rows(hs.bench({"poisson": A, "lopsided": bad}, preconds=["jacobi", "amg"], repeat=2, maxiter=3))
    by = {(r["system"], r["preconditioner"]): r for r in rows}
    assert by[("poisson", "jacobi")]["status"].startswith("not converged")
    assert by[("poisson", "jacobi")]["iterations"] == 3
    assert by[("poisson", "jacobi")]["rel_residual"] > 1e-8
    lopsided = [r for r in rows if r["system"] == "lopsided"]
    assert len(lopsided) == 1 and "symmetric" in lopsided[0]["status"]
    assert "lopsided" in lopsided[0]["status"]


def test_a_given_right_hand_side_and_a_list_of_matrices():
    A = SYSTEMS["poisson-3d"]()[0]
    b = np.random.default_rng(3).standard_normal(A.shape[0])
    (r,) = _rows(hs.bench({"p": (A, b)}, preconds="ic0", repeat=1))
    x, info = hs.solve(A, b, precond="ic0")
    assert r["iterations"] == info.iterations
    (r0,) = _rows(hs.bench([A], preconds=["ic0"], repeat=1))
    assert r0["system"] == "system-0"


@pytest.mark.parametrize(
    "kwargs, named",
    [
        (dict(preconds=["amgg"]), "preconds"),
        (dict(preconds=[]), "preconds"),
        (dict(preconds=["ic0", "ic0"]), "preconds"),
        (dict(repeat=0), "repeat"),
        (dict(repeat=1.5), "repeat"),
        (dict(rtol=-1.0), "rtol"),
        (dict(maxiter=-1), "maxiter"),
        (dict(omega=2.5), "omega"),
        (dict(amg={"sweep": 2}), "amg"),
        (dict(amg={"strength_threshold": -1.0}), "amg"),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(kwargs, named):
    A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(20, 20), format="csr")
    with pytest.raises(ValueError, match=f"^{named}"):
        hs.bench({"a": A}, **{"preconds": ["amg"], **kwargs})


@pytest.mark.parametrize("matrices", [{}, 3, {"a": (1, 2, 3)}, {1: sp.eye(3)}, {"a": {"B": 1}}])
def test_bad_matrices_raise_value_error(matrices):
    with pytest.raises(ValueError, match="^matrices"):
        hs.bench(matrices)
