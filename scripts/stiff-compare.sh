#!/usr/bin/env bash
# The stiff-solver comparison of docs/PERFORMANCE.md ("Stiff IVPs against diffsol and SciPy"):
#   1. hookean-ode's BdfSolver and diffsol's BDF side by side
#      (benches/stiff-compare, a workspace of its own: diffsol stays out of CI):
#      the time at the first rung of the rtol ladder that meets error 1e-4
#      (rust.csv), and the time at 1e-4 fitted over the rungs of a finer ladder
#      with errors from 1e-5 to 1e-3 (rust-fit.csv; see the bench's docs),
#   2. SciPy's solve_ivp(method="BDF") in a venv this script creates
#      (scripts/stiff_scipy.py, same problems, tolerances and error measure),
#   3. our tolerance sweep (crates/hookean-ode/examples/stiff_set.rs).
# Timings are medians of REPEATS runs; the machine is shared, so the load
# average is printed with the results.
#
# usage: scripts/stiff-compare.sh [REPEATS] [OUTDIR]
set -euo pipefail
cd "$(dirname "$0")/.."
REPEATS="${1:-11}"
OUT="${2:-target/stiff-compare-results}"
VENV="${VENV:-target/stiff-compare-venv}"
mkdir -p "$OUT"

echo "load average before: $(cat /proc/loadavg)" | tee "$OUT/load.txt"

# 1. ours and diffsol.
(cd benches/stiff-compare && CARGO_TARGET_DIR=../../target/stiff-compare cargo build --release --locked)
target/stiff-compare/release/stiff-compare "$REPEATS" | tee "$OUT/rust.csv"
target/stiff-compare/release/stiff-compare fit "$REPEATS" | tee "$OUT/rust-fit.csv"

# 2. SciPy: the rtol ladder of the Rust side to where it reaches 1e-4, and the
#    statistics at 1e-4, 1e-6, 1e-8.
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
    "$VENV/bin/pip" install --quiet numpy scipy
fi
"$VENV/bin/python" scripts/stiff_scipy.py target "$REPEATS" | tee "$OUT/scipy.csv"
"$VENV/bin/python" scripts/stiff_scipy.py sweep 1 1e-4 1e-6 1e-8 | tee "$OUT/scipy-sweep.csv"

# 3. Our tolerance sweep (error against rtol, statistics).
cargo run --release --quiet -p hookean-ode --example stiff_set -- "$REPEATS" \
    | tee "$OUT/sweep.csv"

echo "load average after: $(cat /proc/loadavg)" | tee -a "$OUT/load.txt"
