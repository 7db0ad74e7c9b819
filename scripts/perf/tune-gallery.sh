#!/usr/bin/env bash
# Issue 42's bar for `hookean tune`: on each of pyamg's gallery matrices (the
# peers' set of scripts/peers/peers.py), within its budget, tune's winner is
# never slower than the default configuration, within 5% of the best of an
# exhaustive run over the same grid, and faster than pyamg's default smoothed
# aggregation; the same input and budget give the same winner.
#
#   scripts/perf/tune-gallery.sh [BUDGET] [ROUNDS]   # default 30 s, 5 rounds
#
# Environment: SET (default target/peers/set: the matrices; written with
# `peers.py write` when missing), VENV (default target/peers/venv: a venv with
# pyamg, scipy and numpy, made as scripts/peers/compare.sh makes it),
# HOOKEAN (default target/release/hookean, built when missing).
#
# Per matrix, one thread:
#  1. `hookean tune --budget BUDGET` twice (the winners must agree) and
#     `hookean tune --exhaustive` once (the whole grid: minutes per matrix);
#  2. in one run, ROUNDS interleaved rounds of the budgeted winner's, the
#     exhaustive winner's and the default's `hookean solve` command lines, each
#     with `--repeat 3` (timed warm, as tune times its candidates: a process's
#     first solve pays its page faults), and of pyamg's smoothed aggregation
#     (`peers.py pyamg`), the best total kept;
#  3. one line per matrix: the four best totals (ms), the ratios and the
#     verdicts. Timings mean something only on a quiet machine.
set -euo pipefail
BUDGET=${1:-30}
ROUNDS=${2:-5}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SET=${SET:-$ROOT/target/peers/set}
VENV=${VENV:-$ROOT/target/peers/venv}
HOOKEAN=${HOOKEAN:-$ROOT/target/release/hookean}
WORK=$ROOT/target/tune-gallery
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 RAYON_NUM_THREADS=1
log() { echo "[tune-gallery $(date +%H:%M:%S)] $*" >&2; }

if [ ! -x "$VENV/bin/python" ]; then
  log "making the venv $VENV"
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install --quiet pyamg==5.4.1 scipy==1.17.1 numpy==2.4.6
fi
PY="$VENV/bin/python $ROOT/scripts/peers/peers.py"
[ -f "$SET/set.json" ] || { log "writing the gallery into $SET"; mkdir -p "$SET"; $PY write "$SET"; }
[ -x "$HOOKEAN" ] || (cd "$ROOT" && cargo build --release -p hookean-cli)
mkdir -p "$WORK"

names=$("$VENV/bin/python" -c '
import json, sys
for name, m in json.load(open(sys.argv[1])).items():
    if not m["spmv_only"] and not name.startswith("cloth"):
        print(name, m["block_size"])' "$SET/set.json")

# The `hookean solve` line of a tune's output, as words after `hookean`.
solve_line() { grep '^hookean solve ' "$1" | head -1 | sed 's/^hookean //'; }

printf '%-14s %10s %10s %10s %10s %8s %8s %8s  %s\n' matrix default_ms tuned_ms exhaust_ms pyamg_ms \
  tuned/def tuned/exh tuned/pya verdict
while read -r name bs; do
  a=$SET/$name.mtx; b=$SET/${name}_b.mtx; ns=$SET/${name}_nullspace.mtx
  sys=("$a" --rhs "$b" --nullspace "$ns" --block-size "$bs")
  log "$name: tune --budget $BUDGET (twice)"
  "$HOOKEAN" --threads 1 tune "${sys[@]}" --budget "$BUDGET" --out "$WORK/$name-budget" --force --quiet \
    > "$WORK/$name-budget.txt"
  "$HOOKEAN" --threads 1 tune "${sys[@]}" --budget "$BUDGET" --quiet > "$WORK/$name-budget2.txt"
  log "$name: tune --exhaustive"
  "$HOOKEAN" --threads 1 tune "${sys[@]}" --exhaustive --out "$WORK/$name-exhaustive" --force --quiet \
    > "$WORK/$name-exhaustive.txt"
  same=yes
  [ "$(solve_line "$WORK/$name-budget.txt")" = "$(solve_line "$WORK/$name-budget2.txt")" ] || same=no
  read -r -a tuned <<< "$(solve_line "$WORK/$name-budget.txt") --repeat 3"
  read -r -a exhaust <<< "$(solve_line "$WORK/$name-exhaustive.txt") --repeat 3"
  default=(solve "${sys[@]}" --precond amg --rtol 1e-8 --repeat 3)
  best() { # best total (s) of the JSON lines of hookean solve or peers.py in $1
    "$VENV/bin/python" -c '
import json, sys
t = [d["setup_s"] + d["solve_s"] for d in map(json.loads, open(sys.argv[1])) if d.get("converged")]
print(min(t) if t else "nan")' "$1"
  }
  : > "$WORK/$name-t.jsonl"; : > "$WORK/$name-e.jsonl"; : > "$WORK/$name-d.jsonl"; : > "$WORK/$name-p.jsonl"
  log "$name: $ROUNDS interleaved rounds"
  for _ in $(seq 1 "$ROUNDS"); do
    "$HOOKEAN" --threads 1 "${tuned[@]}" >> "$WORK/$name-t.jsonl" || true
    "$HOOKEAN" --threads 1 "${exhaust[@]}" >> "$WORK/$name-e.jsonl" || true
    "$HOOKEAN" --threads 1 "${default[@]}" >> "$WORK/$name-d.jsonl" || true
    $PY pyamg "$SET" "$name" --rtol 1e-8 >> "$WORK/$name-p.jsonl" || true
  done
  "$VENV/bin/python" - "$name" "$(best "$WORK/$name-d.jsonl")" "$(best "$WORK/$name-t.jsonl")" \
    "$(best "$WORK/$name-e.jsonl")" "$(best "$WORK/$name-p.jsonl")" "$same" <<'EOF'
import sys
name, d, t, e, p, same = sys.argv[1], *map(float, sys.argv[2:6]), sys.argv[6]
ok = []
ok.append("never slower than the default" if t <= d * 1.0 else "SLOWER THAN THE DEFAULT")
ok.append("within 5% of exhaustive" if t <= 1.05 * e else "NOT within 5% of exhaustive")
ok.append("faster than pyamg" if t < p else "NOT faster than pyamg")
ok.append("same winner twice" if same == "yes" else "DIFFERENT WINNERS")
print(f"{name:14} {1e3*d:10.3f} {1e3*t:10.3f} {1e3*e:10.3f} {1e3*p:10.3f} {t/d:8.3f} {t/e:8.3f} {t/p:8.3f}  "
      + "; ".join(ok))
EOF
done <<< "$names"
