#!/usr/bin/env python3
"""The Python half of scripts/peers/compare.sh (issue 29's peer comparison).

  peers.py write DIR                 pyamg's gallery matrices as Matrix Market files
  peers.py cloth DIR N K A.mtx b.mtx    a cloth system of write_bench_system into the set
  peers.py pyamg DIR NAME [--rtol R]    pyamg's smoothed aggregation on one matrix (JSON line)
  peers.py table RESULTS.jsonl DIR      the markdown tables of a run

Every matrix NAME of the set is DIR/NAME.mtx (symmetric coordinate), with its
right-hand side DIR/NAME_b.mtx and near-nullspace DIR/NAME_nullspace.mtx (dense
array, one column per mode) beside it; DIR/set.json holds, per name, the
generator, the unknowns per node (block size), rows, nonzeros and whether the
matrix is only for the SpMV timing. Needs numpy, scipy and pyamg (the venv of
compare.sh).
"""
import json
import os
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse as sp

# Right-hand sides of the gallery: uniform on [0, 1), this seed (pyamg's
# examples solve with a random b).
SEED = 29


def write_system(out, name, a, b, nullspace, block_size, generator, spmv_only=False):
    """Writes NAME.mtx (the lower triangle, symmetric), NAME_b.mtx, NAME_nullspace.mtx."""
    a = sp.csr_array(a)
    asym = abs(a - a.T).max() if a.nnz else 0.0
    scale = abs(a).max()
    if asym > 1e-10 * scale:
        sys.exit(f"{name}: not symmetric (max |A - A^T| = {asym:.3e})")
    a = sp.csr_array((a + a.T) / 2)  # round-off asymmetry removed (DG 1.8e-12, bar3d-p1 5.5e-12)
    a.sum_duplicates()
    a.sort_indices()
    scipy.io.mmwrite(f"{out}/{name}.mtx", sp.coo_array(a), symmetry="symmetric", precision=17)
    scipy.io.mmwrite(f"{out}/{name}_b.mtx", np.asarray(b, float).reshape(-1, 1), precision=17)
    scipy.io.mmwrite(f"{out}/{name}_nullspace.mtx", np.asarray(nullspace, float).reshape(a.shape[0], -1),
                     precision=17)
    return {"generator": generator, "block_size": block_size, "rows": a.shape[0],
            "nnz": int(a.nnz), "modes": int(np.asarray(nullspace).reshape(a.shape[0], -1).shape[1]),
            "spmv_only": spmv_only}


def tet_bar(nx, ny, nz, length):
    """Vertices and tetrahedra of the box [0, length] x [0, 1] x [0, 1], nx x ny x nz
    cubes of side 1 / ny, each cut into the 6 tetrahedra around its main diagonal."""
    h = length / nx
    xs, ys, zs = np.arange(nx + 1) * h, np.arange(ny + 1) / ny, np.arange(nz + 1) / nz
    v = np.array([(x, y, z) for x in xs for y in ys for z in zs])

    def vid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    tets = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                c = [vid(i + (m >> 2 & 1), j + (m >> 1 & 1), k + (m & 1)) for m in range(8)]
                # the 6 paths from corner 0 to corner 7 along the cube's edges
                for p, q in ((4, 6), (4, 5), (2, 6), (2, 3), (1, 5), (1, 3)):
                    tets.append((c[0], c[p], c[q], c[7]))
    t = np.array(tets)
    # pyamg's p13d_local weights by the signed volume: orient every tetrahedron positively
    e = v[t[:, 1:]] - v[t[:, :1]]
    flip = np.linalg.det(e) < 0
    t[flip, 1], t[flip, 2] = t[flip, 2], t[flip, 1].copy()
    return v, t


def clamp(a, nullspace, vertices, dim, fixed_nodes):
    """A and the rigid-body modes without the unknowns of the fixed nodes (Dirichlet)."""
    keep = np.ones(vertices.shape[0] * dim, bool)
    for n in fixed_nodes:
        keep[dim * n:dim * n + dim] = False
    a = sp.csr_array(a)[keep][:, keep]
    return a, nullspace[keep]


def write(out):
    from pyamg import gallery
    os.makedirs(out, exist_ok=True)
    rng = np.random.default_rng(SEED)
    entries = {}

    def add(name, a, nullspace, block_size, generator, spmv_only=False):
        print(f"writing {name} ({a.shape[0]} rows)", file=sys.stderr)
        b = rng.random(a.shape[0])
        entries[name] = write_system(out, name, a, b, nullspace, block_size, generator, spmv_only)

    bar = gallery.load_example("bar")
    add("bar", bar["A"], bar["B"], 3,
        "pyamg `gallery.load_example('bar')`: 3D elasticity, trilinear hexahedra, clamped end removed; its B (6 rigid-body modes)")
    v, t = tet_bar(80, 10, 10, 8.0)
    a, modes = gallery.linear_elasticity_p1(v, t, format="csr")
    a, modes = clamp(a, modes, v, 3, np.flatnonzero(v[:, 0] == 0.0))
    add("bar3d-p1", a, modes, 3,
        "pyamg `gallery.linear_elasticity_p1`: bar 8 x 1 x 1, 80 x 10 x 10 cubes of 6 tetrahedra, E = 1e5, nu = 0.3, end x = 0 clamped; its 6 rigid-body modes")
    a, modes = gallery.linear_elasticity((100, 100), format="csr")
    add("elasticity2d", a, modes, 2,
        "pyamg `gallery.linear_elasticity((100, 100))`: 2D Q1 elasticity, E = 1e5, nu = 0.3, Dirichlet boundary; its B (3 rigid-body modes)")
    dg = gallery.load_example("local_disc_galerkin_diffusion")
    add("dg", dg["A"], dg["B"], 1,
        "pyamg `gallery.load_example('local_disc_galerkin_diffusion')`: 2D DG diffusion, p = 5 (21 unknowns per element); its B (constant)")
    a = gallery.poisson((40, 40, 40), format="csr")
    add("poisson3d", a, np.ones(a.shape[0]), 1,
        "pyamg `gallery.poisson((40, 40, 40))`: 7-point Laplacian, Dirichlet; B = constant")
    for m in (50, 80):
        a = gallery.poisson((m, m, m), format="csr")
        add(f"poisson3d-{m}", a, np.ones(a.shape[0]), 1,
            f"pyamg `gallery.poisson(({m}, {m}, {m}))` (SpMV only)", spmv_only=True)
    a, modes = gallery.linear_elasticity((250, 250), format="csr")
    add("elasticity2d-250", a, modes, 2,
        "pyamg `gallery.linear_elasticity((250, 250))` (SpMV only)", spmv_only=True)
    merge_set(out, entries)


def merge_set(out, entries):
    path = f"{out}/set.json"
    have = json.load(open(path)) if os.path.exists(path) else {}
    have.update(entries)
    json.dump(have, open(path, "w"), indent=1)


def cloth(out, n, k, a_path, b_path):
    """The cloth system `write_bench_system N K` wrote, as clothN-kK.mtx / _b.mtx, with
    the three translations per particle as its near-nullspace."""
    name = f"cloth{n}-k{k}"
    a = scipy.io.mmread(a_path).tocsr()
    b = scipy.io.mmread(b_path).ravel()
    modes = np.zeros((a.shape[0], 3))
    for c in range(3):
        modes[c::3, c] = 1.0
    merge_set(out, {name: write_system(
        out, name, a, b, modes, 3,
        f"hookean `write_bench_system {n} {k}`: the implicit-Euler cloth system of "
        f"`bench-precond --n {n} --k {k}`; the 3 translations")})


def read_system(d, name):
    a = sp.csr_array(scipy.io.mmread(f"{d}/{name}.mtx"))
    b = np.asarray(scipy.io.mmread(f"{d}/{name}_b.mtx")).ravel()
    nullspace = np.asarray(scipy.io.mmread(f"{d}/{name}_nullspace.mtx"))
    return a, b, nullspace


def run_pyamg(d, name, rtol):
    """pyamg's smoothed aggregation with the near-nullspace and its defaults (symmetric
    strength, theta = 0; standard aggregation; Jacobi-smoothed prolongator; symmetric
    Gauss-Seidel pre- and post-smoothing; pinv on the coarsest level), as CG's
    preconditioner (one V-cycle), from x = 0 to |r| <= rtol |b|. The set-up includes
    the conversion to BSR with the system's block size. Seeded, so that the iteration
    count is the same in every run."""
    import pyamg
    np.random.seed(SEED)  # pyamg's spectral-radius estimates start from np.random vectors
    meta = json.load(open(f"{d}/set.json"))[name]
    a, b, nullspace = read_system(d, name)
    bs = meta["block_size"]
    t0 = time.perf_counter()
    ab = a.tobsr(blocksize=(bs, bs)) if bs > 1 else a
    ml = pyamg.smoothed_aggregation_solver(ab, B=nullspace)
    setup = time.perf_counter() - t0
    res = []
    t0 = time.perf_counter()
    x = ml.solve(b, x0=np.zeros_like(b), tol=rtol, accel="cg", maxiter=1000, residuals=res)
    solve = time.perf_counter() - t0
    rel = float(np.linalg.norm(b - a @ x) / np.linalg.norm(b))
    print(json.dumps({"tool": "pyamg", "precond": "sa", "iterations": len(res) - 1,
                      "setup_s": setup, "solve_s": solve, "rel_residual": rel,
                      "converged": rel <= 10 * rtol, "levels": len(ml.levels),
                      "operator_complexity": ml.operator_complexity()}))


TOOLS = ["hookean csr", "hookean block", "hookean csr gs", "eigen", "amgcl sa", "amgcl sa+nullspace", "pyamg"]
PRECONDS = ["jacobi", "ssor", "ic0", "ic", "ic-natural", "amg", "damped_jacobi", "ilu0", "sa", "all"]
# Eigen's preconditioner of the same class as ours
SAME_CLASS = {"jacobi": ["jacobi"], "ssor": ["ssor"], "ic0": ["ic-natural", "ic"]}


def order(seq, x):
    return seq.index(x) if x in seq else len(seq)


def table(results, d):
    """The matrices; one markdown table of the solvers, the best total (set-up + solve) of
    the rounds per matrix, tool and preconditioner (a solver that failed in every round
    shows its reason); the SpMV table; and issue 29's bars, where hookean stands."""
    meta = json.load(open(f"{d}/set.json"))
    print("| matrix | generator | rows | nonzeros | unknowns per node | near-nullspace modes |")
    print("|---|---|---|---|---|---|")
    for name, m in meta.items():
        print(f"| {name} | {m['generator']} | {m['rows']} | {m['nnz']} | {m['block_size']} | {m['modes']} |")
    print()
    rows = [json.loads(line) for line in open(results) if line.strip()]
    best, failed = {}, {}
    for r in rows:
        if r.get("kind") == "spmv":
            continue
        key = (r["name"], r["tool"], r.get("precond") or r.get("relax"))
        if r.get("error") or not r.get("converged", True):
            failed.setdefault(key, r.get("error") or f"not converged ({r.get('iterations')} iterations, "
                              f"residual {r.get('rel_residual', float('nan')):.1e})")
            continue
        if key not in best or total(r) < total(best[key]):
            best[key] = r
    print("| matrix | tool | preconditioner | iterations | set-up (s) | solve (s) | total (s) | rel. residual |")
    print("|---|---|---|---|---|---|---|---|")
    keys = sorted(set(best) | set(failed),
                  key=lambda k: (list(meta).index(k[0]), order(TOOLS, k[1]), order(PRECONDS, k[2])))
    for k in keys:
        if k in best:
            r = best[k]
            print(f"| {k[0]} | {k[1]} | {k[2]} | {r['iterations']} | {r['setup_s']:.4f} | "
                  f"{r['solve_s']:.4f} | {total(r):.4f} | {r['rel_residual']:.1e} |")
        else:
            print(f"| {k[0]} | {k[1]} | {k[2]} | failed: {failed[k]} | | | | |")
    spmv = [r for r in rows if r.get("kind") == "spmv"]
    sbest = {}
    for r in spmv:
        key = (r["name"], r["tool"])
        if key not in sbest or r["spmv_s"] < sbest[key]["spmv_s"]:
            sbest[key] = r
    if sbest:
        print()
        print("| matrix | rows | nonzeros | kernel | index bytes | time (ms), best | bytes streamed (MB) | "
              "triad on as many bytes (GB/s) | bound (ms) | time / bound | time / bound with 4-byte indices |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for (name, tool), r in sorted(sbest.items(), key=lambda kv: (list(meta).index(kv[0][0]), kv[0][1])):
            bound = r["bytes"] / (r["triad_gbs"] * 1e9)
            n, nnz = r["rows"], r["nnz"]
            bound4 = (12.0 * nnz + 4.0 * (n + 1) + 16.0 * n) / (r["triad_gbs"] * 1e9)
            print(f"| {name} | {n} | {nnz} | {tool} | {r['index_bytes']} | {1e3 * r['spmv_s']:.3f} | "
                  f"{r['bytes'] / 1e6:.1f} | {r['triad_gbs']:.1f} | {1e3 * bound:.3f} | "
                  f"{r['spmv_s'] / bound:.2f} | {r['spmv_s'] / bound4:.2f} |")
    bars(meta, best, failed, sbest)


def bars(meta, best, failed, sbest):
    """Issue 29's "must be true" lines, measured in this run: hookean's best over its
    storages against the peers' best row of the named kind."""
    print("\nIssue 29's bars in this run (hookean: the better of csr and block storage; the multigrid "
          "with the near-nullspace and pyamg's smoother, symmetric Gauss-Seidel, where that row "
          "exists, else its default block Jacobi):\n")

    def pick(name, tools, preconds):
        rs = [best[(name, t, p)] for t in tools for p in preconds if (name, t, p) in best]
        return min(rs, key=total) if rs else None

    ours_tools = ["hookean csr", "hookean block"]
    for name, m in meta.items():
        if m["spmv_only"] or name.startswith("cloth"):
            continue
        amg = pick(name, ["hookean csr gs"], ["amg"]) or pick(name, ours_tools, ["amg"])
        sa = pick(name, ["pyamg"], ["sa"])
        cl = pick(name, ["amgcl sa", "amgcl sa+nullspace"], ["damped_jacobi", "ilu0"])
        line = f"- {name}: "
        if amg and sa:
            line += (f"multigrid {amg['iterations']} iterations vs pyamg SA {sa['iterations']} "
                     f"(bar <= {1.25 * sa['iterations']:.0f}: {'met' if amg['iterations'] <= 1.25 * sa['iterations'] else 'not met'}), "
                     f"total {total(amg):.4f} s vs pyamg {total(sa):.4f} s ({total(amg) / total(sa):.2f}x: "
                     f"{'met' if total(amg) <= total(sa) else 'not met'})")
        else:
            line += "multigrid or pyamg row missing"
        if cl and amg and name in ("poisson3d", "elasticity2d"):
            line += (f"; vs AMGCL's best SA {total(cl):.4f} s ({total(amg) / total(cl):.2f}x: "
                     f"{'met' if total(amg) <= total(cl) else 'not met'})")
        for ours, theirs in SAME_CLASS.items():
            o = pick(name, ["hookean csr"], [ours])
            e = pick(name, ["eigen"], theirs[:1])
            if o and e:
                line += (f"; {ours} {o['iterations']} vs Eigen {theirs[0]} {e['iterations']} its, "
                         f"time {total(o) / total(e):.2f}x")
        print(line)
    for (name, tool), r in sbest.items():
        if tool.startswith("hookean"):
            bound = r["bytes"] / (r["triad_gbs"] * 1e9)
            bound4 = (12.0 * r["nnz"] + 4.0 * (r["rows"] + 1) + 16.0 * r["rows"]) / (r["triad_gbs"] * 1e9)
            e = sbest.get((name, "eigen CSR"))
            print(f"- SpMV {name}: {r['spmv_s'] / bound:.2f}x its own bound, {r['spmv_s'] / bound4:.2f}x "
                  f"the 4-byte-index bound (bar 1.5x)"
                  + (f"; Eigen {e['spmv_s'] * e['triad_gbs'] * 1e9 / e['bytes']:.2f}x its bound, "
                     f"hookean / Eigen time {r['spmv_s'] / e['spmv_s']:.2f}" if e else ""))


def total(r):
    return r["setup_s"] + r["solve_s"]


def main(argv):
    if len(argv) >= 2 and argv[0] == "write":
        write(argv[1])
    elif len(argv) == 6 and argv[0] == "cloth":
        cloth(*argv[1:])
    elif len(argv) >= 3 and argv[0] == "pyamg":
        rtol = float(argv[argv.index("--rtol") + 1]) if "--rtol" in argv else 1e-8
        run_pyamg(argv[1], argv[2], rtol)
    elif len(argv) == 3 and argv[0] == "table":
        table(argv[1], argv[2])
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
