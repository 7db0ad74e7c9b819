#!/usr/bin/env bash
# The measurement behind docs/ARCHITECTURE.md ("hookean-geometry and parry3d"):
# hookean-geometry against parry3d-f64 on the same meshes and queries
# (benches/geometry-compare, a workspace of its own: parry3d stays out of CI).
# It checks that both give the same answers before it prints a time.
#
# usage: scripts/geometry-compare.sh [CLOTH_N] [REPEAT]   (defaults 128 7)
set -euo pipefail
cd "$(dirname "$0")/.."
echo "load average before: $(cat /proc/loadavg)"
(cd benches/geometry-compare && CARGO_TARGET_DIR=../../target/geometry-compare cargo build --release --locked)
for threads in 1 2; do
  echo "== RAYON_NUM_THREADS=$threads"
  RAYON_NUM_THREADS=$threads target/geometry-compare/release/geometry-compare "${1:-128}" "${2:-7}"
done
echo "load average after: $(cat /proc/loadavg)"
