#!/usr/bin/env bash
# A/B of the scalar-CSR PCG (issue 29, part B): an older `hookean` (OLD), this
# checkout's release build and Eigen's PCG, one thread, interleaved rounds, on the
# matrices scripts/peers/compare.sh writes. Prints "tool preconditioner iterations
# total-seconds" per run; take the best of the rounds.
#
#   OLD=$(scripts/build-ref COMMIT) scripts/peers/scalar-ab.sh [ROUNDS]
#
# Environment: SET (default target/peers/set), EIGEN (default target/peers/eigen_pcg),
# MATRICES (default "poisson3d elasticity2d dg bar3d-p1").
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SET=${SET:-$ROOT/target/peers/set}
EIGEN=${EIGEN:-$ROOT/target/peers/eigen_pcg}
NEW=${NEW:-$ROOT/target/release/hookean}
OLD=${OLD:?OLD=path of the hookean binary to compare against}
MATRICES=${MATRICES:-poisson3d elasticity2d dg bar3d-p1}
export OMP_NUM_THREADS=1
show() { python3 -c "import sys, json
for d in map(json.loads, sys.stdin):
    print('$1', d.get('precond'), d.get('iterations'), round(d.get('setup_s', 0) + d.get('solve_s', 0), 4))"; }
for _ in $(seq "${1:-3}"); do
  for m in $MATRICES; do
    echo "== $m"
    "$OLD" --threads 1 solve "$SET/$m.mtx" --rhs "$SET/${m}_b.mtx" --format csr --precond jacobi,ssor,ic0 | show old
    "$NEW" --threads 1 solve "$SET/$m.mtx" --rhs "$SET/${m}_b.mtx" --format csr --precond jacobi,ssor,ic0 | show new
    "$EIGEN" "$SET/$m.mtx" "$SET/${m}_b.mtx" --rtol 1e-8 --precond jacobi,ssor,ic-natural --label "$m" 2>/dev/null | show eigen
  done
done
