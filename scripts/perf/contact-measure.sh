#!/usr/bin/env bash
# The contact cost table of docs/PERFORMANCE.md: cloth-table and cloth-fold
# against the same cloth with no collider (free-table.toml, free-fold.toml;
# pinned-table.toml: that cloth pinned at two corners, deforming as it drapes),
# and the drape and cloth-sphere against the base commit's build, interleaved,
# ROUNDS rounds; prints every run's stepping wall time (summary.json's
# wall_s), Newton iterations and rejected steps. Run under scripts/quiet.
# With OLD (a release build of an earlier commit), every contact scene and
# its baselines also run with OLD, each right before NEW's run (an A/B in
# one run; labels old-*).
#   NEW=target/release/hookean BASE=$(scripts/build-ref f2acdf6) ROUNDS=3 scripts/perf/contact-measure.sh
#   NEW=target/release/hookean OLD=$(scripts/build-ref 12596ff) ROUNDS=3 scripts/perf/contact-measure.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
new=${NEW:-target/release/hookean}
base=${BASE:-}
old=${OLD:-}
rounds=${ROUNDS:-3}
out=$(mktemp -d)
run() { # label binary scene
  "$2" run "$3" --out "$out/r" --quiet --force > /dev/null
  python3 -c "import json,sys; s=json.load(open('$out/r/summary.json')); print('%-20s %7.3f s  newton %4d  steps %4d  rejected %d' % ('$1', s['wall_s'], s['newton_iterations'], s['steps'], s['rejected_steps']))"
}
for r in $(seq "$rounds"); do
  echo "round $r"
  for scene in scenes/cloth-table.toml scripts/perf/contact/free-table.toml \
    scripts/perf/contact/pinned-table.toml scenes/cloth-fold.toml scripts/perf/contact/free-fold.toml; do
    label=$(basename "$scene" .toml)
    if [ -n "$old" ]; then
      run "old-$label" "$old" "$scene"
    fi
    run "$label" "$new" "$scene"
  done
  if [ -n "$base" ]; then
    run drape-base "$base" scenes/drape.toml
    run drape-new "$new" scenes/drape.toml
    run sphere-base "$base" scenes/cloth-sphere.toml
    run sphere-new "$new" scenes/cloth-sphere.toml
  fi
done
rm -rf "$out"
