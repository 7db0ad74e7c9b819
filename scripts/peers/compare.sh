#!/usr/bin/env bash
# Issue 29's peer comparison: `hookean solve` next to pyamg, AMGCL and Eigen on
# pyamg's gallery matrices and two cloth systems, one thread, |r| <= 1e-8 |b|
# from x = 0 (docs/PERFORMANCE.md, "Multigrid against pyamg and AMGCL").
# Run by hand, not in CI (it installs and downloads):
#
#   scripts/peers/compare.sh [ROUNDS]        # default 3; prints the markdown tables
#
# Environment: WORK (default target/peers: everything lands there), AMGCL_GIT
# (default https://github.com/ddemidov/amgcl; a local mirror path works too),
# CLOTH (default 64,128: the cloth sizes N, k = 1e4), PEER_TIMEOUT (seconds
# per tool run, default 600), CARGO_TARGET_DIR.
#
#  1. Installs what it needs: Eigen 3.4 (Debian's libeigen3-dev; g++, git and
#     python3-venv too, with apt-get when missing), a venv with pyamg, scipy and numpy from PyPI, AMGCL 1.4.9
#     cloned at run time (commit checked; nothing of it is kept in the repo);
#     compiles scripts/peers/eigen_pcg.cpp and scripts/amgcl-peer/amgcl_solve.cpp
#     (g++ -O3, no -march=native, like our release build); builds `hookean`,
#     the example write_bench_system and the bench `preconditioners` (release).
#  2. Writes the matrices (scripts/peers/peers.py write, and the cloth systems)
#     as NAME.mtx with NAME_b.mtx and NAME_nullspace.mtx beside each.
#  3. ROUNDS interleaved rounds; in each, matrix by matrix, one fresh set-up and
#     solve of every solver (each tool in its own process, one thread):
#       hookean   `hookean --threads 1 solve --format csr --block-size B
#                  --precond jacobi,ssor,ic0,amg --nullspace NAME_nullspace.mtx`
#                  (and --format block where B = 3), and "hookean csr gs": the
#                  multigrid alone with pyamg's smoother (--amg-smoother
#                  gauss-seidel: symmetric block Gauss-Seidel), off cloth
#       eigen     ConjugateGradient (UpLo = Lower) + jacobi, ic (AMD), ic-natural, ssor (eigen_pcg)
#       amgcl     smoothed aggregation + CG, smoothers damped_jacobi and ilu0:
#                 "sa" with AMGCL's defaults (3x3 block values where B = 3, else
#                 scalar with aggregation on B x B blocks) and, where the
#                 near-nullspace has more modes than B (elasticity), "sa+nullspace"
#                 with those modes and eps_strong = 0 (AMGCL's nullspace tutorial)
#       pyamg     smoothed_aggregation_solver(A as BSR, B = nullspace) + CG
#     and the CSR SpMV alone (eigen_pcg --spmv, the bench's --spmv-files) on the
#     matrices of 1e5 unknowns or more, each next to a triad on as many bytes.
#  4. The table: per matrix, tool and preconditioner the best total of the
#     rounds; a solver that failed in every round is a row with its reason.
# Progress on stderr; raw JSON lines in $WORK/results.jsonl.
set -euo pipefail

ROUNDS=${1:-3}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
WORK=${WORK:-$ROOT/target/peers}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
CLOTH=${CLOTH:-64,128}
PEER_TIMEOUT=${PEER_TIMEOUT:-600}
RTOL=1e-8
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
mkdir -p "$WORK/set"
log() { echo "[peers $(date +%H:%M:%S)] $*" >&2; }

# 1. Tools.
deb() {  # deb PACKAGE TEST...: installs the Debian package unless TEST succeeds
    local package=$1; shift
    "$@" >/dev/null 2>&1 && return
    log "installing $package"
    command -v apt-get >/dev/null && [ "$(id -u)" = 0 ] ||
        { echo "need the Debian package $package (or its equivalent)" >&2; exit 1; }
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -q "$package" >&2 || { apt-get update -q >&2 && apt-get install -y -q "$package" >&2; }
}
EIGEN_INCLUDE=${EIGEN_INCLUDE:-/usr/include/eigen3}
deb libeigen3-dev test -f "$EIGEN_INCLUDE/Eigen/Core"
deb g++ command -v g++
deb git command -v git
deb python3-venv python3 -m venv --help
VENV=$WORK/venv
if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c "import pyamg, scipy" 2>/dev/null; then
    log "creating $VENV (pyamg, scipy, numpy from PyPI)"
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install --quiet pyamg==5.4.1 scipy==1.17.1 numpy==2.4.6
fi
PY="$VENV/bin/python $ROOT/scripts/peers/peers.py"
AMGCL_GIT=${AMGCL_GIT:-https://github.com/ddemidov/amgcl}
AMGCL_TAG=1.4.9
AMGCL_COMMIT=28296c2a95894b3732a89b2f75f257a957b09857
AMGCL_SRC=$WORK/amgcl-$AMGCL_TAG
[ -d "$AMGCL_SRC" ] ||
    git -c advice.detachedHead=false clone -q --depth 1 --branch "$AMGCL_TAG" "$AMGCL_GIT" "$AMGCL_SRC" >&2
[ "$(git -C "$AMGCL_SRC" rev-parse HEAD)" = "$AMGCL_COMMIT" ] ||
    { echo "AMGCL $AMGCL_TAG is not commit $AMGCL_COMMIT" >&2; exit 1; }
compile() {  # compile SOURCE BINARY FLAGS...: when the source is newer
    local src=$1 bin=$2; shift 2
    if [ ! -x "$bin" ] || [ "$src" -nt "$bin" ]; then
        log "compiling $bin"
        nice -n 10 g++ -std=c++14 -O3 -DNDEBUG "$@" "$src" -o "$bin"
    fi
}
compile "$ROOT/scripts/peers/eigen_pcg.cpp" "$WORK/eigen_pcg" -I"$EIGEN_INCLUDE"
compile "$ROOT/scripts/amgcl-peer/amgcl_solve.cpp" "$WORK/amgcl_solve" -DAMGCL_NO_BOOST -fopenmp -I"$AMGCL_SRC"
log "building hookean, write_bench_system and the bench preconditioners (release)"
(cd "$ROOT" && nice -n 10 cargo build --release --locked -p hookean-cli --bin hookean --example write_bench_system >&2)
BENCH=$(cd "$ROOT" && nice -n 10 cargo bench --locked --no-run --bench preconditioners 2>&1 |
    sed -n 's/.*Executable .*(\(.*\)).*/\1/p' | tail -1)
case $BENCH in /*) ;; *) BENCH=$ROOT/$BENCH ;; esac
HOOKEAN=$CARGO_TARGET_DIR/release/hookean
WRITER=$CARGO_TARGET_DIR/release/examples/write_bench_system
NULLSPACE_FLAG=$("$HOOKEAN" solve --help | grep -q -- '--nullspace' && echo yes || echo no)

# 2. The matrices.
SET=$WORK/set
[ -f "$SET/set.json" ] && grep -q poisson3d-80 "$SET/set.json" || $PY write "$SET"
IFS=, read -r -a CLOTH_N <<< "$CLOTH"
for n in "${CLOTH_N[@]}"; do
    if ! grep -q "\"cloth$n-k1e4\"" "$SET/set.json"; then
        log "writing cloth$n-k1e4"
        "$WRITER" "$n" 1e4 "$WORK/raw-cloth$n" --force >&2
        $PY cloth "$SET" "$n" 1e4 "$WORK/raw-cloth$n-A.mtx" "$WORK/raw-cloth$n-b.mtx"
    fi
done
# name block_size modes spmv_only, one line per matrix, in the set's order
mapfile -t MATRICES < <("$VENV/bin/python" -c "
import json, sys
for k, v in json.load(open('$SET/set.json')).items():
    print(k, v['block_size'], v['modes'], int(v['spmv_only']), v['rows'])")

# 3. Interleaved rounds.
OUT=$WORK/results.jsonl
: > "$OUT"
run() {  # run NAME TOOL CMD...: CMD's JSON lines, tagged; a run that printed none is a row with its reason
    local name=$1 tool=$2 rc=0 out reason; shift 2
    out=$(timeout "$PEER_TIMEOUT" "$@" 2>"$WORK/last.err") || rc=$?
    if grep -q '^{' <<< "$out"; then
        grep '^{' <<< "$out" | sed "s/^{/{\"round\":$round,\"name\":\"$name\",\"tool\":\"$tool\",/" >> "$OUT"
    else
        reason=$(grep -v '^\s*$' "$WORK/last.err" | tail -1 | tr -d '"\\' | cut -c1-200)
        [ "$rc" = 124 ] && reason="timed out after $PEER_TIMEOUT s"
        log "  $tool failed on $name: $reason"
        printf '{"round":%d,"name":"%s","tool":"%s","precond":"all","error":"exit %d: %s"}\n' \
            "$round" "$name" "$tool" "$rc" "$reason" >> "$OUT"
    fi
}
{
    echo "date: $(date -u '+%Y-%m-%d %H:%M UTC')"
    echo "machine: $(nproc --all) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(free -g | awk '/Mem:/ {print $2}') GiB"
    echo "hookean: $(git -C "$ROOT" rev-parse --short HEAD); $(rustc --version)"
    echo "g++: $(g++ --version | head -1); Eigen $(sed -n 's/#define EIGEN_[A-Z]*_VERSION //p' "$EIGEN_INCLUDE/Eigen/src/Core/util/Macros.h" | paste -sd.); AMGCL $AMGCL_TAG"
    echo "python: $("$VENV/bin/python" -c 'import pyamg, scipy, numpy, sys; print(sys.version.split()[0], "pyamg", pyamg.__version__, "scipy", scipy.__version__, "numpy", numpy.__version__)')"
    echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
} > "$WORK/machine.txt"
cat "$WORK/machine.txt" >&2
for round in $(seq 1 "$ROUNDS"); do
    for m in "${MATRICES[@]}"; do
        read -r name bs modes spmv_only rows <<< "$m"
        a=$SET/$name.mtx b=$SET/${name}_b.mtx ns=$SET/${name}_nullspace.mtx
        if [ "$spmv_only" = 1 ] || [ "$rows" -ge 100000 ]; then
            log "round $round/$ROUNDS, $name: SpMV ($(cut -d' ' -f1 /proc/loadavg))"
            run "$name" "eigen" "$WORK/eigen_pcg" "$a" --spmv 1 --label "$name"
            run "$name" "hookean" "$BENCH" --spmv-files "$a"
        fi
        [ "$spmv_only" = 1 ] && continue
        log "round $round/$ROUNDS, $name ($(cut -d' ' -f1 /proc/loadavg))"
        extra=()
        [ "$NULLSPACE_FLAG" = yes ] && extra=(--nullspace "$ns")
        run "$name" "hookean csr" "$HOOKEAN" --threads 1 solve "$a" --rhs "$b" --rtol "$RTOL" \
            --format csr --block-size "$bs" --precond jacobi,ssor,ic0,amg "${extra[@]}"
        if [ "$bs" = 3 ]; then
            run "$name" "hookean block" "$HOOKEAN" --threads 1 solve "$a" --rhs "$b" --rtol "$RTOL" \
                --format block --precond jacobi,ssor,ic0,amg "${extra[@]}"
        fi
        if [ "$NULLSPACE_FLAG" = yes ] && [[ $name != cloth* ]]; then
            run "$name" "hookean csr gs" "$HOOKEAN" --threads 1 solve "$a" --rhs "$b" --rtol "$RTOL" \
                --format csr --block-size "$bs" --precond amg --amg-smoother gauss-seidel "${extra[@]}"
        fi
        run "$name" "eigen" "$WORK/eigen_pcg" "$a" "$b" --rtol "$RTOL" --precond jacobi,ic,ic-natural,ssor --label "$name"
        if [ "$bs" = 3 ]; then
            run "$name" "amgcl sa" "$WORK/amgcl_solve" "$a" "$b" --value block3 --relax damped_jacobi,ilu0 \
                --repeat 1 --rtol "$RTOL" --label "$name"
        else
            run "$name" "amgcl sa" "$WORK/amgcl_solve" "$a" "$b" --value scalar --block-size "$bs" \
                --relax damped_jacobi,ilu0 --repeat 1 --rtol "$RTOL" --label "$name"
        fi
        if [ "$modes" -gt "$bs" ]; then
            # AMGCL 1.4.9 aggregates every level on blocks of aggr.block_size: with 3 modes
            # on 2-unknown blocks the coarse sizes are not multiples of 2, so there point-wise.
            nbs=$bs
            [ $((modes % bs)) = 0 ] || nbs=1
            run "$name" "amgcl sa+nullspace" "$WORK/amgcl_solve" "$a" "$b" --value scalar --block-size "$nbs" \
                --nullspace "$ns" --eps-strong 0 --relax damped_jacobi,ilu0 --repeat 1 --rtol "$RTOL" --label "$name"
        fi
        run "$name" "pyamg" $PY pyamg "$SET" "$name" --rtol "$RTOL"
    done
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$WORK/machine.txt"
log "$(tail -1 "$WORK/machine.txt")"

# 4. The table.
{
    sed 's/^/    /' "$WORK/machine.txt"
    echo
    $PY table "$OUT" "$SET"
} | tee "$WORK/table.md"
