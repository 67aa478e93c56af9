#!/bin/bash
# A/B wall-time comparison of two bench_events binaries on one case, for a
# shared, noisy machine: single runs of A and B alternate ROUNDS times, and
# the per-round ratio B/A is summarised (median, min, max) next to each
# binary's median and best collisions/s.
#   bench/ab_events.sh OLD/bench_events NEW/bench_events [CASE-PREFIX] [ROUNDS]
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: $0 BENCH_A BENCH_B [CASE-PREFIX (hs-N4000)] [ROUNDS (10)]" >&2
  exit 2
fi
a=$1 b=$2 case=${3:-hs-N4000} rounds=${4:-10}
collisions_per_s() { "$1" --repeat 1 --only "$case" | tail -1 | cut -d'|' -f7; }
for _ in $(seq "$rounds"); do
  echo "$(collisions_per_s "$a") $(collisions_per_s "$b")"
done | /usr/bin/python3 -c '
import statistics as st, sys
rows = [tuple(map(float, line.split())) for line in sys.stdin]
a = [r[0] for r in rows]; b = [r[1] for r in rows]; q = [y / x for x, y in rows]
print("collisions/s  A: median %.3g best %.3g | B: median %.3g best %.3g" % (st.median(a), max(a), st.median(b), max(b)))
print("ratio B/A over %d rounds: median %.3f (min %.3f, max %.3f)" % (len(q), st.median(q), min(q), max(q)))'
