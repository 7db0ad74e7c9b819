"""pyamg's gallery systems: 2D and 3D linear elasticity with their rigid-body
near-nullspace, 3D Poisson, the DG diffusion matrix (small sizes: the tests
check answers, not speed)."""

import os
import pathlib
import shutil

import numpy as np
import pytest

pyamg = pytest.importorskip("pyamg")


def cube_tets(n):
    """The vertices and tetrahedra of the unit cube cut into n^3 cubes of 6 tets each."""
    g = np.linspace(0.0, 1.0, n + 1)
    vertices = np.array([(x, y, z) for z in g for y in g for x in g])
    idx = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)
    tets = []
    for k in range(n):
        for j in range(n):
            for i in range(n):
                c = [idx(i + a, j + b, k + d) for d in (0, 1) for b in (0, 1) for a in (0, 1)]
                # Kuhn's 6 tetrahedra along the diagonal c[0] - c[7].
                for p in ((1, 3), (3, 2), (2, 6), (6, 4), (4, 5), (5, 1)):
                    tets.append([c[0], c[p[0]], c[p[1]], c[7]])
    return vertices, np.array(tets)


def elasticity_2d(n=24):
    A, B = pyamg.gallery.linear_elasticity((n, n), format="bsr")
    return A, B


def elasticity_3d(n=6):
    vertices, tets = cube_tets(n)
    A, B = pyamg.gallery.linear_elasticity_p1(vertices, tets, format="csr")
    # Clamped at x = 0 (pyamg's matrix has no boundary condition: singular).
    free = np.repeat(vertices[:, 0] > 0.0, 3)
    A = A.tocsr()[free][:, free]
    return A.tocsr(), np.ascontiguousarray(B[free])


def poisson_3d(n=16):
    A = pyamg.gallery.poisson((n, n, n), format="csr")
    return A, None


def dg_diffusion():
    """pyamg's local discontinuous Galerkin diffusion matrix (its example
    `local_disc_galerkin_diffusion`, 966 unknowns) with its near-nullspace."""
    d = pyamg.gallery.load_example("local_disc_galerkin_diffusion")
    return d["A"].tocsr(), np.ascontiguousarray(d["B"], dtype=np.float64)


SYSTEMS = {
    "elasticity-2d": elasticity_2d,
    "elasticity-3d": elasticity_3d,
    "poisson-3d": poisson_3d,
    "dg-diffusion": dg_diffusion,
}


@pytest.fixture(params=sorted(SYSTEMS))
def system(request):
    """(name, A, near-nullspace or None, b) with b a fixed random vector."""
    A, B = SYSTEMS[request.param]()
    b = np.random.default_rng(7).standard_normal(A.shape[0])
    return request.param, A, B, b


def relative_residual(A, x, b):
    return np.linalg.norm(b - A @ x) / np.linalg.norm(b)


ROOT = pathlib.Path(__file__).resolve().parents[3]


def hookean_bin():
    """The `hookean` command to compare with: $HOOKEAN_BIN, the workspace's
    debug build, or one on the PATH; None when there is none."""
    for candidate in (os.environ.get("HOOKEAN_BIN"), ROOT / "target/debug/hookean", shutil.which("hookean")):
        if candidate and pathlib.Path(candidate).is_file():
            return str(candidate)
    return None


def example_bin(name, env):
    """The workspace's example `name` to compare with: $`env`, or its debug
    or release build; None when it is not built."""
    for candidate in (
        os.environ.get(env),
        ROOT / "target/debug/examples" / name,
        ROOT / "target/release/examples" / name,
    ):
        if candidate and pathlib.Path(candidate).is_file():
            return str(candidate)
    return None
