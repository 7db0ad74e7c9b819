#!/usr/bin/env bash
# AMGCL next to our MIC(0)-PCG and AMG-PCG on the systems of
# `hookean bench-precond` (docs/perf/amgcl-peer.md; issue 15's 0.3x bar).
# Run by hand, not in CI:
#
#   scripts/amgcl-compare.sh [N] [K_LIST] [ROUNDS]      # defaults: 256 1e2,1e4,1e6 3
#
# What it does (everything lands in $WORK, default target/amgcl-peer):
#  1. clones AMGCL (header-only) at a pinned tag at run time from $AMGCL_GIT
#     (default https://github.com/ddemidov/amgcl; a local mirror path works
#     too) and checks the commit; nothing of AMGCL is kept in this repository;
#  2. compiles scripts/amgcl-peer/amgcl_solve.cpp against it (g++ -O3
#     -fopenmp -DAMGCL_NO_BOOST, no -march=native, like our release build);
#  3. builds `hookean` and the example `write_bench_system` (release) and
#     writes the bench-precond systems (cloth N x N, k in K_LIST) to
#     Matrix Market, then checks that `hookean solve --precond mic0` on the
#     files gives the rows, nnz and iteration count of `hookean bench-precond`;
#  4. ROUNDS interleaved rounds; in each, for 1 and 2 threads and each k:
#     our MIC(0) then AMG (`hookean solve --threads T --precond mic0,amg`,
#     one process), then AMGCL (OMP_NUM_THREADS=T) with 3x3 block values
#     (static_matrix<double,3,3>), smoothed aggregation, CG, and the
#     smoothers $AMGCL_RELAX (default damped_jacobi,ilu0; one process).
#     Each run is one set-up and one solve from x = 0 to |r| <= 1e-8 |b|;
#     the summary takes the best of the rounds and the per-round ratios.
# `uptime` is printed before and after. Raw JSON lines: $WORK/results.jsonl.
set -euo pipefail

N=${1:-256}
KS=${2:-1e2,1e4,1e6}
ROUNDS=${3:-3}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${WORK:-$ROOT/target/amgcl-peer}
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
PYAMGCL_VERSION=1.0.0.post4
PYAMGCL_SHA256=8e2a1ba8e922ec9a6030fd953e50511adc89a54f6fe1164b6371f105e649e21d
mkdir -p "$WORK"

# 1. AMGCL.
AMGCL_GIT=${AMGCL_GIT:-https://github.com/ddemidov/amgcl}
AMGCL_TAG=1.4.9
AMGCL_COMMIT=28296c2a95894b3732a89b2f75f257a957b09857
AMGCL_SRC=$WORK/amgcl-$AMGCL_TAG
[ -d "$AMGCL_SRC" ] || git clone -q --depth 1 --branch "$AMGCL_TAG" "$AMGCL_GIT" "$AMGCL_SRC"
[ "$(git -C "$AMGCL_SRC" rev-parse HEAD)" = "$AMGCL_COMMIT" ] ||
    { echo "AMGCL $AMGCL_TAG is not commit $AMGCL_COMMIT" >&2; exit 1; }

# 2. The driver.
DRIVER=$WORK/amgcl_solve
if [ ! -x "$DRIVER" ] || [ "$ROOT/scripts/amgcl-peer/amgcl_solve.cpp" -nt "$DRIVER" ]; then
    echo "compiling $DRIVER ($(g++ --version | head -1))" >&2
    nice -n 10 g++ -std=c++14 -O3 -DNDEBUG -DAMGCL_NO_BOOST -fopenmp -I"$AMGCL_SRC" \
        "$ROOT/scripts/amgcl-peer/amgcl_solve.cpp" -o "$DRIVER"
fi
AMGCL_RELAX=${AMGCL_RELAX:-damped_jacobi,ilu0}

# 3. Our binary and the systems.
(cd "$ROOT" && nice -n 10 cargo build --release --locked -p hookean-cli --bin hookean --example write_bench_system >&2)
HOOKEAN=${HOOKEAN:-$CARGO_TARGET_DIR/release/hookean}
WRITER=$CARGO_TARGET_DIR/release/examples/write_bench_system
IFS=, read -r -a KLIST <<< "$KS"
for k in "${KLIST[@]}"; do
    p=$WORK/cloth$N-k$k
    [ -f "$p-A.mtx" ] || "$WRITER" "$N" "$k" "$p" >&2
done
echo "check: bench-precond vs hookean solve on the files (MIC(0) iterations, rows, nnz)" >&2
"$HOOKEAN" --threads 2 bench-precond --n "$N" --k "$KS" --precond mic0 --repeat 1 2>/dev/null \
    > "$WORK/check-bench.jsonl"
for k in "${KLIST[@]}"; do
    p=$WORK/cloth$N-k$k
    "$HOOKEAN" --threads 2 solve "$p-A.mtx" --rhs "$p-b.mtx" --format block --precond mic0 \
        2>/dev/null > "$WORK/check-solve-$k.jsonl"
done
python3 - "$WORK" "$KS" <<'PY'
import json, sys
work, ks = sys.argv[1], sys.argv[2].split(",")
bench = [json.loads(l) for l in open(f"{work}/check-bench.jsonl")]
ok = True
for k, rb in zip(ks, bench):
    rs = json.loads(open(f"{work}/check-solve-{k}.jsonl").readline())
    same = all(rb[f] == rs[f] for f in ("rows", "nnz", "iterations"))
    ok &= same
    print(f"k={k}: bench-precond rows {rb['rows']} nnz {rb['nnz']} its {rb['iterations']}; "
          f"solve on file rows {rs['rows']} nnz {rs['nnz']} its {rs['iterations']}: "
          f"{'same' if same else 'DIFFERENT'}", file=sys.stderr)
sys.exit(0 if ok else 1)
PY

# 4. Interleaved rounds.
OUT=$WORK/results.jsonl
: > "$OUT"
echo "uptime before: $(uptime)" | tee "$WORK/uptime.txt" >&2
for round in $(seq 1 "$ROUNDS"); do
    for t in 1 2; do
        for k in "${KLIST[@]}"; do
            p=$WORK/cloth$N-k$k
            tag="\"round\":$round,\"k\":\"$k\",\"threads\":$t"
            echo "round $round, $t thread(s), k = $k ($(cut -d' ' -f1-3 /proc/loadavg))" >&2
            "$HOOKEAN" --threads "$t" solve "$p-A.mtx" --rhs "$p-b.mtx" --format block \
                --precond mic0,amg 2>/dev/null | sed "s/^{/{$tag,/" >> "$OUT"
            OMP_NUM_THREADS=$t "$DRIVER" "$p-A.mtx" "$p-b.mtx" --value block3 \
                --relax "$AMGCL_RELAX" --repeat 1 --label "cloth$N-k$k" \
                | sed "s/^{/{$tag,/" >> "$OUT" || echo "AMGCL failed (k=$k, $t threads)" >&2
        done
    done
done
echo "uptime after: $(uptime)" | tee -a "$WORK/uptime.txt" >&2

python3 - "$OUT" <<'PY'
import json, sys, collections
rows = [json.loads(l) for l in open(sys.argv[1])]
def name(r):
    if r["solver"] != "amgcl":
        return "ours " + r["precond"]
    return f"amgcl {r['value']} {r['relax']}"
by = collections.defaultdict(list)
for r in rows:
    by[(r["threads"], r["k"], name(r))].append(r)
print("| threads | k | solver | iterations | set-up (ms) | solve (ms) | total (ms), best | rel. residual | / our MIC(0), best | / our MIC(0), per round |")
print("|---|---|---|---|---|---|---|---|---|---|")
for (t, k) in sorted({(t, k) for (t, k, _) in by}, key=lambda x: (x[0], float(x[1]))):
    mic = by[(t, k, "ours mic0")]
    mic_best = min(r["setup_s"] + r["solve_s"] for r in mic)
    mic_round = {r["round"]: r["setup_s"] + r["solve_s"] for r in mic}
    for (t2, k2, nm), rs in sorted(by.items()):
        if (t2, k2) != (t, k):
            continue
        best = min(rs, key=lambda r: r["setup_s"] + r["solve_s"])
        tot = best["setup_s"] + best["solve_s"]
        per = ", ".join(f"{(r['setup_s'] + r['solve_s']) / mic_round[r['round']]:.2f}" for r in sorted(rs, key=lambda r: r["round"]))
        print(f"| {t} | {k} | {nm} | {best['iterations']} | {1e3*best['setup_s']:.0f} | {1e3*best['solve_s']:.0f} | "
              f"{1e3*tot:.0f} | {best['rel_residual']:.1e} | {tot/mic_best:.2f} | {per} |")
PY
