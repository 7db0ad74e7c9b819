#!/usr/bin/env bash
# The reuse question measured by hand (issue 42): the drape at N x N for
# DURATION s, run once per policy that a scene can express, each printing the
# run's preconditioner set-up plus PCG solve time (summary.json's phases_s)
# and its PCG iterations. Compare with the chosen policy of
#
#   hookean export-system scenes/drape.toml --every 1 --set cloth.n=N --set duration=DURATION --out SEQ
#   hookean bench --sequence SEQ --out BENCH
#
# (its total should lie within 10% of the best line below). The lagged IC(0)
# and MIC(0) policies (ic0-keep-N, mic0-keep-N) have no scene key and are
# not run here. Run it under scripts/quiet or on an idle machine:
#
#   scripts/perf/sequence-by-hand.sh N [DURATION=1] [HOOKEAN=target/release/hookean]
set -euo pipefail
n=${1:?usage: sequence-by-hand.sh N [DURATION] [HOOKEAN]}
duration=${2:-1}
hookean=${3:-target/release/hookean}
out=$(mktemp -d); trap 'rm -rf "$out"' EXIT
policies=(
  "amg-rebuild solver.preconditioner=amg solver.amg.reuse=rebuild"
  "amg-refill solver.preconditioner=amg solver.amg.reuse=refill"
  "amg-keep-2 solver.preconditioner=amg solver.amg.reuse=keep solver.amg.keep_updates=2"
  "amg-keep-4 solver.preconditioner=amg solver.amg.reuse=keep solver.amg.keep_updates=4"
  "amg-keep-8 solver.preconditioner=amg solver.amg.reuse=keep solver.amg.keep_updates=8"
  "ic0-rebuild solver.preconditioner=ic0"
  "mic0-rebuild solver.preconditioner=mic0"
)
printf '%-14s %12s %12s %12s %10s\n' policy setup_s solve_s total_s cg_iters
for p in "${policies[@]}"; do
  read -r name sets <<<"$p"
  args=()
  for s in $sets; do args+=(--set "$s"); done
  "$hookean" run scenes/drape.toml --set cloth.n="$n" --set duration="$duration" \
    --set output.frame_rate=1 "${args[@]}" --out "$out/$name" --quiet >/dev/null
  python3 - "$out/$name/summary.json" "$name" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
p = s["phases_s"]
setup, solve = p["preconditioner_setup"], p["solve"]
print(f"{sys.argv[2]:<14} {setup:12.3f} {solve:12.3f} {setup + solve:12.3f} {s['cg_iterations']:10d}")
PY
done
