#!/usr/bin/env bash
# "Every shipped scene writes the same frames" (docs/PERFORMANCE.md, "The machine, the builds, how to rerun"): runs
# every scenes/*.toml with a release build of a baseline commit (its own
# scene file, read from git) and with this checkout's build, on THREADS
# kernel threads each (default 1), and compares the OBJ frames (scripts/frames-diff.py): how many are
# byte-identical, the largest vertex-coordinate difference and vertex
# distance (m) over all frames, and the last frame's mean distance.
#
# usage: BASE_BIN=path/to/hookean-of-BASE [THREADS=2] scripts/frames-ab.sh [BASE] [OUTDIR]
set -euo pipefail
cd "$(dirname "$0")/.."
BASE="${1:-f2acdf6}"
OUT="${2:-target/frames-ab}"
HEAD_BIN="${HEAD_BIN:-target/release/hookean}"
THREADS="${THREADS:-1}"
: "${BASE_BIN:?set BASE_BIN to a release build of $BASE}"
mkdir -p "$OUT"
# The baseline's scenes with the files they name (meshes in data/, given
# relative to the scene), laid out as in the repository.
rm -rf "$OUT/base-tree"
mkdir -p "$OUT/base-tree"
git archive "$BASE" scenes data | tar -x -C "$OUT/base-tree"
echo "scene,frames,byte_identical,max_vertex_diff_m,max_distance_m,last_frame_mean_distance_m"
for scene in scenes/*.toml; do
    name=$(basename "$scene" .toml)
    if [ ! -f "$OUT/base-tree/$scene" ]; then
        echo "$name,new since $BASE,,"
        continue
    fi
    rm -rf "$OUT/base-$name" "$OUT/head-$name"
    "$BASE_BIN" run --quiet --threads "$THREADS" --out "$OUT/base-$name" "$OUT/base-tree/$scene" > /dev/null
    "$HEAD_BIN" run --quiet --threads "$THREADS" --out "$OUT/head-$name" "$scene" > /dev/null
    python3 scripts/frames-diff.py "$OUT/base-$name" "$OUT/head-$name" "$name"
done
