#!/usr/bin/env bash
# Wall time of one full-protocol replicate with each capture reading
# (bonding.capture_site = end_face, end_point), measured side by side: for
# every scenario and seed the two readings run one right after the other,
# alone on the machine (one process), so machine drift hits both alike.
# Prints one line per run and, per scenario, the median of each reading and
# their ratio.
#
# Usage: bench/capture_site_timing.sh RINGSIM SEEDS SCENARIO...
#   e.g. bench/capture_site_timing.sh build/ringsim "1 2 3" 1-baseline 4-passive-selection
set -euo pipefail
if [[ $# -lt 3 ]]; then sed -n '2,11p' "$0"; exit 1; fi
bin=$1 seeds=$2
shift 2
here=$(cd "$(dirname "$0")/.." && pwd)
for s in "$@"; do
  for seed in $seeds; do
    for site in end_face end_point; do
      w=$("$bin" replicate "$here/jobs/scenarios/$s.toml" --seed "$seed" --set bonding.capture_site=$site --json 2>/dev/null |
          /usr/bin/python3 -c 'import json,sys; j=json.load(sys.stdin); print(j["wall_seconds"], j["termination"], j["collisions"])')
      echo "$s seed $seed $site $w"
    done
  done
done | tee /dev/stderr | /usr/bin/python3 -c '
import sys, statistics, collections
t = collections.defaultdict(list)
for line in sys.stdin:
    f = line.split()
    t[(f[0], f[3])].append(float(f[4]))
for s in dict.fromkeys(k[0] for k in t):
    a, b = statistics.median(t[(s, "end_face")]), statistics.median(t[(s, "end_point")])
    print(f"{s}: median end_face {a:.2f} s, end_point {b:.2f} s, ratio face/point {a / b:.2f}")
'
