#!/usr/bin/env bash
# "No path slower", in instructions (issue 38): the paths of
# scripts/perf/paths-ab.sh, shortened so that callgrind runs them in minutes,
# counted by valgrind's callgrind on one thread for a release build of a
# baseline commit and for a second build. Instruction counts do not depend on
# the machine's load, so this can run beside other work (wall-time claims
# cannot). The baseline's scenes and data are read from git, as
# scripts/frames-ab.sh does. Prints one row per path: base and head
# instructions (millions) and the relative change.
#
# usage: BASE_BIN=$(scripts/build-ref C) [HEAD_BIN=... HEAD_REV=D] scripts/perf/paths-instructions.sh C [OUTDIR]
#   HEAD_BIN defaults to this checkout's release build, run on this
#   checkout's scenes; with HEAD_REV, on that commit's scenes and data.
#   ONLY=REGEX counts only the paths whose name matches (grep -E), e.g.
#   ONLY='hookean solve' for the five solve paths. E.g.
#   BASE_BIN=$(scripts/build-ref 43482a4) HEAD_BIN=$(scripts/build-ref b85faee) HEAD_REV=b85faee \
#     scripts/perf/paths-instructions.sh 43482a4
set -euo pipefail
cd "$(dirname "$0")/../.."
BASE="${1:?usage: BASE_BIN=... scripts/perf/paths-instructions.sh BASE [OUTDIR]}"
OUT="${2:-target/paths-instructions}"
HEAD_BIN="${HEAD_BIN:-target/release/hookean}"
: "${BASE_BIN:?set BASE_BIN to a release build of $BASE (scripts/build-ref $BASE)}"
command -v valgrind > /dev/null || { echo "valgrind is needed (apt-get install valgrind)" >&2; exit 2; }
mkdir -p "$OUT"
rm -rf "$OUT/base-tree"
mkdir -p "$OUT/base-tree"
git archive "$BASE" scenes data | tar -x -C "$OUT/base-tree"
head_tree=.
if [ -n "${HEAD_REV:-}" ]; then
  head_tree="$OUT/head-tree"
  rm -rf "$head_tree"
  mkdir -p "$head_tree"
  git archive "$HEAD_REV" scenes data | tar -x -C "$head_tree"
fi

# count SIDE BIN TREE ARGS...: the instructions (millions) of one run, with
# the tree's scene and data paths; a failed run stops the script.
count() {
  local side=$1 bin=$2 tree=$3
  shift 3
  local args=()
  for a in "$@"; do args+=("${a//@/$tree/}"); done
  if ! RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file="$OUT/cg.$side" \
    "$bin" "${args[@]}" > "$OUT/log.$side" 2>&1; then
    echo "failed: $bin ${args[*]}" >&2
    tail -5 "$OUT/log.$side" >&2
    exit 1
  fi
  grep -m1 '^summary:' "$OUT/cg.$side" | awk '{ printf "%.1f", $2 / 1e6 }'
}

run=(run --quiet --threads 1 --force --set output.frame_rate=0 --out "$OUT/run")
# name|arguments ("@" is the tree: the baseline's for BASE_BIN, HEAD_REV's or
# this checkout's for HEAD_BIN)
paths=(
  "cloth-sphere|${run[*]} @scenes/cloth-sphere.toml"
  "jelly|${run[*]} @scenes/jelly.toml"
  "rope|${run[*]} @scenes/rope.toml"
  "drape (cloth.n=32 duration=1)|${run[*]} --set cloth.n=32 --set duration=1 @scenes/drape.toml"
  "cloth-table (duration=0.3)|${run[*]} --set duration=0.3 @scenes/cloth-table.toml"
  "drape-filtered (duration=0.5)|${run[*]} --set duration=0.5 @scenes/drape-filtered.toml"
  "cloth-fold (duration=0.2)|${run[*]} --set duration=0.2 @scenes/cloth-fold.toml"
  "drape (cloth.n=16 duration=0.5 bdf)|${run[*]} --set cloth.n=16 --set duration=0.5 --set integrator.method=bdf @scenes/drape.toml"
  "drape (cloth.n=16 duration=0.5 bdf2-variable)|${run[*]} --set cloth.n=16 --set duration=0.5 --set integrator.method=bdf2-variable @scenes/drape.toml"
)
for p in jacobi ssor ic0 mic0 amg; do
  paths+=("hookean solve cloth16, $p, 5 repeats|solve @data/cloth16-A.mtx --rhs @data/cloth16-b.mtx --precond $p --repeat 5")
done

echo "| path | $BASE (M instructions) | ${HEAD_REV:-head} | change |"
echo "|---|---|---|---|"
for entry in "${paths[@]}"; do
  name=${entry%%|*}
  if [ -n "${ONLY:-}" ] && ! grep -qE -- "$ONLY" <<< "$name"; then
    continue
  fi
  read -r -a args <<< "${entry#*|}"
  echo "$name ..." >&2
  base=$(count base "$BASE_BIN" "$OUT/base-tree" "${args[@]}")
  head=$(count head "$HEAD_BIN" "$head_tree" "${args[@]}")
  awk -v n="$name" -v a="$base" -v b="$head" \
    'BEGIN { printf "| %s | %.1f | %.1f | %+.3f%% |\n", n, a, b, 100 * (b - a) / a }'
done
