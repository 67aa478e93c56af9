#!/usr/bin/env bash
# Wall time of one replicate with each of two values of one key, measured
# side by side: for every scenario and seed the two values run one right
# after the other (one process), so machine drift hits both alike. Prints
# one line per run and, per scenario, the median wall of each value and
# their ratio (A / B).
#
# Usage: bench/paired_timing.sh RINGSIM SEEDS KEY A B SCENARIO... [-- --set KEY=VALUE...]
#   e.g. bench/paired_timing.sh build/ringsim "1 2 3" bonding.joint articulated welded \
#            1-baseline 4-passive-selection -- --set run.t_max=500
# Anything after `--` goes to every run.
set -euo pipefail
if [[ $# -lt 6 ]]; then sed -n '2,12p' "$0"; exit 1; fi
bin=$1 seeds=$2 key=$3 a=$4 b=$5
shift 5
scenarios=()
while [[ $# -gt 0 && $1 != -- ]]; do scenarios+=("$1"); shift; done
[[ $# -gt 0 && $1 == -- ]] && shift
extra=("$@")
here=$(cd "$(dirname "$0")/.." && pwd)
for s in "${scenarios[@]}"; do
  for seed in $seeds; do
    for value in "$a" "$b"; do
      # Exit status 3: the replicate ended in an error, its JSON says which.
      rc=0
      j=$("$bin" replicate "$here/jobs/scenarios/$s.toml" --seed "$seed" --set "$key=$value" "${extra[@]}" --json) || rc=$?
      if [[ $rc -ne 0 && $rc -ne 3 ]]; then
        echo "paired_timing: $s, seed $seed, $key=$value: ringsim exited $rc (its message above)" >&2
        exit 1
      fi
      w=$(/usr/bin/python3 -c 'import json,sys; j=json.load(sys.stdin); print(j["wall_seconds"], j["termination"], j["collisions"])' <<<"$j")
      echo "$s seed $seed $value $w"
    done
  done
done | tee /dev/stderr | /usr/bin/python3 -c '
import sys, statistics, collections
a, b = sys.argv[1], sys.argv[2]
t = collections.defaultdict(list)
for line in sys.stdin:
    f = line.split()
    t[(f[0], f[3])].append(float(f[4]))
complete = [s for s in dict.fromkeys(k[0] for k in t) if t[(s, a)] and t[(s, b)]]
for s in complete:
    ma, mb = statistics.median(t[(s, a)]), statistics.median(t[(s, b)])
    print(f"{s}: median {a} {ma:.2f} s, {b} {mb:.2f} s, ratio {a}/{b} {ma / mb:.2f}")
sys.exit(0 if complete and len(complete) == len({k[0] for k in t}) else 1)
' "$a" "$b"
