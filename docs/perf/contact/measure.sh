#!/usr/bin/env bash
# The contact cost table of docs/PERFORMANCE.md: cloth-table and cloth-fold
# against the same cloth with no collider (free-table.toml, free-fold.toml;
# pinned-table.toml: that cloth pinned at two corners, deforming as it drapes),
# and the drape and cloth-sphere against the base commit's build, interleaved,
# ROUNDS rounds; prints every run's stepping wall time (summary.json's
# wall_s), Newton iterations and rejected steps. Run under /work/bin/quiet.
#   NEW=target/release/hookean BASE=/path/to/f2acdf6/target/release/hookean ROUNDS=3 docs/perf/contact/measure.sh
set -euo pipefail
cd "$(dirname "$0")/../../.."
new=${NEW:-target/release/hookean}
base=${BASE:-}
rounds=${ROUNDS:-3}
out=$(mktemp -d)
run() { # label binary scene
  "$2" run "$3" --out "$out/r" --quiet --force > /dev/null
  python3 -c "import json,sys; s=json.load(open('$out/r/summary.json')); print('%-14s %7.3f s  newton %4d  steps %4d  rejected %d' % ('$1', s['wall_s'], s['newton_iterations'], s['steps'], s['rejected_steps']))"
}
for r in $(seq "$rounds"); do
  echo "round $r"
  run cloth-table "$new" scenes/cloth-table.toml
  run free-table "$new" docs/perf/contact/free-table.toml
  run pinned-table "$new" docs/perf/contact/pinned-table.toml
  run cloth-fold "$new" scenes/cloth-fold.toml
  run free-fold "$new" docs/perf/contact/free-fold.toml
  if [ -n "$base" ]; then
    run drape-base "$base" scenes/drape.toml
    run drape-new "$new" scenes/drape.toml
    run sphere-base "$base" scenes/cloth-sphere.toml
    run sphere-new "$new" scenes/cloth-sphere.toml
  fi
done
rm -rf "$out"
