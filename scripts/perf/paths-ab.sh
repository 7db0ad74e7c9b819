#!/usr/bin/env bash
# "No path slower" (issues 38 and 42): every shipped scene that the baseline
# also has (its own scene file and data, read from git as
# scripts/frames-ab.sh does) and `hookean solve` on data/cloth16 with every
# preconditioner, run by a release build of a baseline commit and by this
# checkout's, ROUNDS interleaved rounds (base, head, base, head, ...), the
# best whole-process wall time of each kept (/usr/bin/time). Prints one row
# per path: best base s, best head s, head / base. Run it under scripts/quiet:
# timings mean something only on a quiet machine.
#
# usage: BASE_BIN=$(scripts/build-ref C) [THREADS=2] scripts/perf/paths-ab.sh C [ROUNDS] [OUTDIR]
set -euo pipefail
cd "$(dirname "$0")/../.."
BASE="${1:?usage: BASE_BIN=... scripts/perf/paths-ab.sh BASE [ROUNDS] [OUTDIR]}"
ROUNDS="${2:-3}"
OUT="${3:-target/paths-ab}"
HEAD_BIN="${HEAD_BIN:-target/release/hookean}"
THREADS="${THREADS:-2}"
: "${BASE_BIN:?set BASE_BIN to a release build of $BASE (scripts/build-ref $BASE)}"
mkdir -p "$OUT"
rm -rf "$OUT/base-tree"
mkdir -p "$OUT/base-tree"
git archive "$BASE" scenes data | tar -x -C "$OUT/base-tree"

# best WHICH TIME: keeps the smaller wall time per path and binary.
declare -A best
keep() {
  local key=$1 t=$2
  if [ -z "${best[$key]:-}" ] || awk -v a="$t" -v b="${best[$key]}" 'BEGIN { exit !(a < b) }'; then
    best[$key]=$t
  fi
}
# timed KEY BIN ARGS...: one whole-process run, its wall time kept; a failed
# run stops the script (a path that fails is not a timing).
timed() {
  local key=$1
  shift
  if ! /usr/bin/time -f "%e" -o "$OUT/time.txt" "$@" > "$OUT/log.txt" 2>&1; then
    echo "failed: $*" >&2
    tail -5 "$OUT/log.txt" >&2
    exit 1
  fi
  keep "$key" "$(cat "$OUT/time.txt")"
}

paths=()
for scene in scenes/*.toml; do
  name=$(basename "$scene" .toml)
  [ -f "$OUT/base-tree/$scene" ] && paths+=("$name")
done
precs="jacobi block-jacobi ssor ic0 mic0 amg"
for r in $(seq 1 "$ROUNDS"); do
  echo "round $r of $ROUNDS (load $(cut -d' ' -f1 /proc/loadavg))" >&2
  for name in "${paths[@]}"; do
    timed "base $name" "$BASE_BIN" run --quiet --threads "$THREADS" --force \
      --set output.frame_rate=0 --out "$OUT/run" "$OUT/base-tree/scenes/$name.toml"
    timed "head $name" "$HEAD_BIN" run --quiet --threads "$THREADS" --force \
      --set output.frame_rate=0 --out "$OUT/run" "scenes/$name.toml"
  done
  for p in $precs; do
    for side in base head; do
      bin=$BASE_BIN
      [ "$side" = head ] && bin=$HEAD_BIN
      timed "$side solve-$p" "$bin" solve data/cloth16-A.mtx --rhs data/cloth16-b.mtx \
        --precond "$p" --repeat 20
    done
  done
done
echo "path,base_s,head_s,head_over_base"
for name in "${paths[@]}" $(printf 'solve-%s ' $precs); do
  awk -v n="$name" -v a="${best["base $name"]}" -v b="${best["head $name"]}" \
    'BEGIN { printf "%s,%.2f,%.2f,%.3f\n", n, a, b, (a > 0 ? b / a : 0) }'
done
