#!/usr/bin/env bash
# Issue 29's "no slowdown on cloth": interleaved rounds of `hookean bench-precond`
# on the cloth systems (N = 64, 128, 256; k = 1e2, 1e4, 1e6; five preconditioners)
# for release builds of several commits; prints per size and preconditioner the
# summed best totals, their ratio to the first binary, and any iteration count
# that differs from the first binary's. Run it under scripts/quiet or on an idle
# machine (docs/PERFORMANCE.md, "Multigrid against pyamg and AMGCL"):
#
#   scripts/perf/cloth-precond-ab.sh ROUNDS base=$(scripts/build-ref COMMIT) new=target/release/hookean ...
set -euo pipefail
rounds=$1; shift
out=$(mktemp -d); trap 'rm -rf "$out"' EXIT
for r in $(seq $rounds); do
  for lb in "$@"; do
    l=${lb%%=*}; b=${lb#*=}
    $b bench-precond --n 64,128,256 --k 1e2,1e4,1e6 --precond jacobi,ssor,ic0,mic0,amg --repeat 3 --threads 2 2>/dev/null > $out/$l-$r.jsonl
  done
done
python3 - "$out" "$@" <<'PY'
import json,sys,glob,collections
out=sys.argv[1]; labels=[a.split('=')[0] for a in sys.argv[2:]]
best={}
for l in labels:
  for f in glob.glob(f"{out}/{l}-*.jsonl"):
    for line in open(f):
      d=json.loads(line); key=(d['n'],d['precond'],d['k'])
      t=d['setup_s']+d['solve_s']
      best.setdefault(l,{}); best[l][key]=min(best[l].get(key,1e9),t)
      best[l][key+('it',)]=d['iterations']
base=labels[0]
tot=collections.defaultdict(float)
for l in labels:
  for k,v in best[l].items():
    if len(k)==3: tot[(l,k[0],k[1])]+=v
print("n precond", *labels, *(f"{l}/{base}" for l in labels[1:]))
for n in (64,128,256):
  for p in ("jacobi","ssor","ic0","mic0","amg"):
    row=[tot[(l,n,p)] for l in labels]
    print(n,p,*("%.4f"%x for x in row),*("%.3f"%(x/row[0]) for x in row[1:]))
for l in labels:
  s=sum(v for k,v in tot.items() if k[0]==l); print("sum",l,"%.4f"%s, "%.3f"%(s/sum(v for k,v in tot.items() if k[0]==base)))
itdiff=[k for k in best[labels[-1]] if len(k)==4 and best[labels[-1]][k]!=best[base].get(k)]
print("iteration differences vs",base,":",itdiff)
PY
