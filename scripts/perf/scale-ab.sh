#!/usr/bin/env bash
# Issue 25's drape A/B (docs/PERFORMANCE.md, "The cloth step and its scaling"): runs `hookean run SCENE --set cloth.n=N --set duration=D --set
# output.frame_rate=0` with each binary in turn, REPS interleaved rounds, and
# prints wall time and peak RSS (/usr/bin/time), the Newton and CG counts,
# rejected steps and the phases of summary.json. Run under scripts/quiet.
#   SCENE=<a drape.toml every binary reads, e.g. f2acdf6's> \
#     scripts/perf/scale-ab.sh N D REPS label=binary[:extra --set args] ...
set -euo pipefail
N=$1; D=$2; R=$3; shift 3
scene=${SCENE:-scenes/drape.toml}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for r in $(seq 1 "$R"); do
  for spec in "$@"; do
    label=${spec%%=*}; rest=${spec#*=}; bin=${rest%%:*}; extra=""
    [[ "$rest" == *:* ]] && extra=${rest#*:}
    # shellcheck disable=SC2086 # extra holds several --set arguments
    /usr/bin/time -f "%e %M" -o "$out/time.txt" "$bin" run "$scene" --set cloth.n="$N" \
      --set duration="$D" --set output.frame_rate=0 $extra --out "$out/r" --force --quiet \
      > "$out/log.txt" 2>&1
    read -r wall rss < "$out/time.txt"
    line=$(grep -o '[0-9]* steps, [0-9]* Newton and [0-9]* CG' "$out/log.txt" || true)
    ph=$(python3 -c "import json;d=json.load(open('$out/r/summary.json'));p=d.get('phases_s');print('rej=%d'%d['rejected_steps'], ' '.join('%s=%.2f'%(k[:5],v) for k,v in p.items()) if p else '')")
    echo "$label N=$N rep=$r wall=$wall rss=$((rss/1024))MB  $line $ph"
  done
done
