#!/usr/bin/env bash
# The drape measurements of docs/PERFORMANCE.md ("The cloth step and its scaling"): a release build of a baseline commit (default c3502ff, main when
# issue 16 was filed) and of this checkout, run interleaved round by round
# (the machine is noisy: ratios within a round are what hold), then the
# physics check (the 64^2 frame at t = 1 s and the final energy against the
# baseline's).
#
# usage: [BASE_BIN=... HEAD_BIN=...] scripts/drape-ab.sh [ROUNDS] [BASELINE] [OUTDIR]
#
# Each round runs, in this order, for 64^2 x 5 s and 128^2 x 1 s: the
# baseline (its own scenes/drape.toml), this checkout with --threads 1, and
# this checkout with --threads 2. Output folders of the 64^2 runs keep their
# frames (frame rate 10) for the physics check; the 128^2 runs write none.
# Prints one markdown row per run and the load average of every round.
set -euo pipefail
cd "$(dirname "$0")/.."
ROUNDS="${1:-3}"
BASE="${2:-c3502ff}"
OUT="${3:-target/drape-ab}"
mkdir -p "$OUT"

# Builds: the baseline in a worktree of its own (target/drape-ab-base), this
# checkout in its usual target directory. BASE_BIN and HEAD_BIN, when set,
# name binaries already built (the baseline's scene is then read from git).
if [ -z "${BASE_BIN:-}" ]; then
    if [ ! -d target/drape-ab-base ]; then
        git worktree add --detach target/drape-ab-base "$BASE"
    fi
    (cd target/drape-ab-base && git checkout --quiet --detach "$BASE" && cargo build --release --locked -p hookean-cli --quiet)
    BASE_BIN=target/drape-ab-base/target/release/hookean
fi
if [ -z "${HEAD_BIN:-}" ]; then
    cargo build --release --locked -p hookean-cli --quiet
    HEAD_BIN=target/release/hookean
fi
BASE_SCENE="$OUT/base-drape.toml"
git show "$BASE:scenes/drape.toml" > "$BASE_SCENE"

run() { # label bin scene threads-args n duration frame-rate
    local label=$1 bin=$2 scene=$3 threads=$4 n=$5 t=$6 fr=$7
    local dir="$OUT/$label-$n"
    rm -rf "$dir"
    local start end
    start=$(date +%s.%N)
    # shellcheck disable=SC2086
    $bin $threads run "$scene" --set cloth.n="$n" --set duration="$t" \
        --set output.frame_rate="$fr" --set output.width=1 --set output.height=1 \
        --out "$dir" --quiet > "$dir.log" 2>&1
    end=$(date +%s.%N)
    python3 - "$dir/summary.json" "$label" "$n" "$t" "$start" "$end" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
label, n, t, start, end = sys.argv[2], sys.argv[3], sys.argv[4], float(sys.argv[5]), float(sys.argv[6])
print(f"| {n}^2, {t} s | {label} | {end - start:.2f} | {d['steps']} | {d['rejected_steps']} | "
      f"{d['newton_iterations']} | {d['cg_iterations']} |")
EOF
}

echo "| run | build | wall (s) | steps | rejected | Newton | CG |"
echo "|---|---|---|---|---|---|---|"
for r in $(seq 1 "$ROUNDS"); do
    echo "<!-- round $r: load average $(cut -d' ' -f1-3 /proc/loadavg) -->"
    for spec in "64 5 10" "128 1 0"; do
        set -- $spec
        run "base-r$r" "$BASE_BIN" "$BASE_SCENE" "" "$1" "$2" "$3"
        run "t1-r$r" "$HEAD_BIN" scenes/drape.toml "--threads 1" "$1" "$2" "$3"
        run "t2-r$r" "$HEAD_BIN" scenes/drape.toml "--threads 2" "$1" "$2" "$3"
    done
done

# Physics: the 64^2 frame at t = 1 s (frame 10) and the final total energy
# of each build of round 1 against the baseline's.
python3 - "$OUT" <<'EOF'
import math, sys
out = sys.argv[1]
def frame(label):
    return [tuple(map(float, l.split()[1:4]))
            for l in open(f"{out}/{label}-64/frame-0010.obj") if l.startswith("v ")]
def energy(label):
    return float(open(f"{out}/{label}-64/steps.csv").read().splitlines()[-1].split(",")[7])
base = frame("base-r1")
for label in ["t1-r1", "t2-r1"]:
    d = [math.dist(p, q) for p, q in zip(frame(label), base)]
    e, e0 = energy(label), energy("base-r1")
    print(f"{label}: frame at t = 1 s {100 * sum(d) / len(d):.2f} cm mean, "
          f"{100 * max(d):.2f} cm max from the baseline; final energy {e:.5f} J "
          f"against {e0:.5f} J ({100 * (e - e0) / abs(e0):+.2f}%)")
EOF
