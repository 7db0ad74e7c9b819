#!/usr/bin/env bash
# Issue 29's line "3D Poisson 40^3 and 2D elasticity at least as fast as
# AMGCL's smoothed aggregation" (docs/PERFORMANCE.md, "Multigrid against pyamg and AMGCL"): ROUNDS interleaved rounds, one thread, of each
# hookean binary's multigrid (block Jacobi, the default; `--nullspace` from
# NAME_nullspace.mtx) and of AMGCL's smoothed aggregation with damped Jacobi
# and ILU(0), on poisson3d (block size 1) and elasticity2d (block size 2) of
# the peers' set. Prints one line per run: matrix, label, set-up, solve,
# total (s), iterations. Run under scripts/quiet.
#   SET=<dir of the peers' matrices> AMGCL=<amgcl_solve> \
#     scripts/perf/amg-setup-ab.sh ROUNDS label=binary ...
set -euo pipefail
R=$1; shift
SET=${SET:-target/peers/set}
AMGCL=${AMGCL:-target/peers/amgcl_solve}
export OMP_NUM_THREADS=1 RAYON_NUM_THREADS=1
json='import json,sys
for line in sys.stdin:
    line = line.strip()
    if not line.startswith("{"):
        continue
    d = json.loads(line)
    label = sys.argv[2] if len(sys.argv) > 2 else "amgcl-" + d["relax"]
    print(sys.argv[1], label, "%.4f %.4f %.4f" % (d["setup_s"], d["solve_s"], d["setup_s"] + d["solve_s"]), d["iterations"])'
for r in $(seq 1 "$R"); do
  for m in poisson3d:1 elasticity2d:2; do
    name=${m%%:*}; bs=${m##*:}
    a=$SET/$name.mtx; b=$SET/${name}_b.mtx; ns=$SET/${name}_nullspace.mtx
    for spec in "$@"; do
      label=${spec%%=*}; bin=${spec#*=}
      "$bin" --threads 1 solve "$a" --rhs "$b" --rtol 1e-8 --format csr --block-size "$bs" \
        --precond amg --nullspace "$ns" | python3 -c "$json" "$name" "$label"
    done
    "$AMGCL" "$a" "$b" --value scalar --block-size "$bs" --relax damped_jacobi,ilu0 --repeat 1 \
      --rtol 1e-8 2>&1 | python3 -c "$json" "$name"
  done
done
