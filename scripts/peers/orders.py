"""MIC(0) and IC(0) PCG iterations of one matrix in several block orders.

The experiment behind the two-domain order of hookean-sparse's block
IC(0)/MIC(0) (precond/two_domain.rs, docs/PERFORMANCE.md): the matrix is
permuted symmetrically (3x3 blocks kept together) into the natural order,
A B S (two domains, then the separator), A B-reversed S (the order the
factor uses), S A B, A-reversed B S and the reversed order; each is written
to OUT as Matrix Market with its right-hand side and solved by
`hookean solve --precond mic0,ic0`, which factors in the file's order when
given the hookean build of a commit before the two-domain order (1bd247e).

usage: python orders.py A.mtx b.mtx OUT HOOKEAN
(needs numpy and scipy: the peers' venv, scripts/peers/peers.py)
"""
import json
import subprocess
import sys

import numpy as np
import scipy.io
import scipy.sparse as sp

a_path, b_path, out, hookean = sys.argv[1:5]
A = scipy.io.mmread(a_path).tocsr()
b = np.asarray(scipy.io.mmread(b_path)).ravel()
n = A.shape[0] // 3
coo = A.tocoo()
last = np.zeros(n, dtype=int)
np.maximum.at(last, coo.row // 3, coo.col // 3)
# The split of TwoDomains::of: A = 0..m, S = m..reach, B = reach..n with
# the domains closest in size.
reach, best = 0, None
for m in range(1, n):
    reach = max(reach, last[m - 1] + 1, m)
    if best is None or abs(m - (n - reach)) < abs(best[0] - best[1]):
        best = (m, n - reach)
m, nb = best
w = n - m - nb
dom_a, sep, dom_b = list(range(m)), list(range(m, m + w)), list(range(m + w, n))
orders = {
    "natural": list(range(n)),
    "A B S": dom_a + dom_b + sep,
    "A B-reversed S": dom_a + dom_b[::-1] + sep,
    "S A B": sep + dom_a + dom_b,
    "A-reversed B S": dom_a[::-1] + dom_b + sep,
    "reversed": list(range(n))[::-1],
}
print(f"{n} block rows: A {m}, separator {w}, B {nb}")
for k, (name, order) in enumerate(orders.items()):
    order = np.array(order)
    scalar = (3 * order[:, None] + np.arange(3)[None, :]).ravel()
    mat, rhs = f"{out}/order{k}.mtx", f"{out}/order{k}_b.mtx"
    scipy.io.mmwrite(mat, sp.coo_matrix(A[scalar][:, scalar]), symmetry="symmetric")
    scipy.io.mmwrite(rhs, b[scalar].reshape(-1, 1))
    run = subprocess.run(
        [hookean, "solve", mat, "--rhs", rhs, "--precond", "mic0,ic0", "--format", "block"],
        capture_output=True, text=True, check=True,
    )
    its = {}
    for line in run.stdout.splitlines():
        try:
            d = json.loads(line)
        except ValueError:
            continue
        its[d.get("precond")] = d.get("iterations")
    print(f"{name:16s} MIC(0) {its.get('mic0')}  IC(0) {its.get('ic0')}")
