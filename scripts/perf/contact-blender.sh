#!/usr/bin/env bash
# The issue's outside reference for the contact cost bar: Blender's cloth
# (an implicit mass-spring solver with its own collision response) on
# cloth-table's setup against the same cloth with no collider, interleaved
# with hookean's cloth-table and free-table, ROUNDS rounds. Run under
# scripts/quiet. Needs `blender` (Debian: apt-get install blender; 3.4.1
# was measured) on the PATH.
#   NEW=target/release/hookean ROUNDS=3 scripts/quiet scripts/perf/contact-blender.sh
# Prints one line per run: the cloth's stepping wall time (Blender: the
# frame loop, 51 frames x 8 substeps = 400 steps of 5 ms; hookean:
# summary.json's wall_s) and, for Blender, the final height range.
set -euo pipefail
cd "$(dirname "$0")/../.."
new=${NEW:-target/release/hookean}
rounds=${ROUNDS:-3}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
hookean() { # label scene
  "$new" run "$2" --out "$out/r" --quiet --force > /dev/null 2>&1
  python3 -c "import json; s=json.load(open('$out/r/summary.json')); print('%-28s %7.3f s  CG %d' % ('$1', s['wall_s'], s['cg_iterations']))"
}
blender_run() { # mode params
  blender -b --factory-startup -P scripts/perf/contact_blender_table.py -- \
    "$PWD/data/table.obj" "$1" 2 "$2" 2>&1 | grep '^BLENDER' | \
    awk '{printf "%-28s %7.3f s  final z %s..%s\n", "blender-" $2 "-" $3, $7, $9, $11}'
}
for r in $(seq "$rounds"); do
  echo "round $r"
  hookean hookean-cloth-table scenes/cloth-table.toml
  hookean hookean-free-table scripts/perf/contact/free-table.toml
  blender_run collide hookean
  blender_run free hookean
  blender_run collide blender
  blender_run free blender
done
