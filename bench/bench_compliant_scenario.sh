#!/usr/bin/env bash
# Scenario 5 (compliant) against Scenario 4 (rigid): wall time per replicate
# over the same horizon, seeds alternating between the two scenarios so that
# machine noise hits both alike; the share of Scenario 5's time inside
# SUNDIALS. docs/COMPLIANT.md, "Coupling: cost".
#
# usage: bench/bench_compliant_scenario.sh RINGSIM T_MAX SEEDS [TIMEOUT_S]
#   e.g. bench/bench_compliant_scenario.sh ./build/ringsim 100 10
# Prints one CSV row per replicate, then the medians and their ratio.
# Extra overrides for both scenarios: RINGSIM_SET="run.contact_tolerance=1e-6 ..."
set -euo pipefail
ringsim=${1:?ringsim binary}
t_max=${2:?t_max}
seeds=${3:?number of seeds}
limit=${4:-600}
here=$(cd "$(dirname "$0")/.." && pwd)
s4="$here/jobs/scenarios/4-passive-selection.toml"
s5="$here/jobs/scenarios/5-compliant.toml"
py=/usr/bin/python3
out=$(mktemp)
trap 'rm -f "$out"' EXIT
echo "scenario,seed,wall_s,events,collisions,bonds,sundials_s,slices,cuts,relaxed,bursts,termination"
for seed in $(seq 1 "$seeds"); do
  for sc in "$s4" "$s5"; do
    name=$(basename "$sc" .toml)
    extra=()
    for kv in ${RINGSIM_SET:-}; do extra+=(--set "$kv"); done
    if timeout "$limit" "$ringsim" replicate "$sc" --seed "$seed" --set run.t_max="$t_max" --set run.steady_state=false \
        "${extra[@]}" --json > "$out" 2>/dev/null; then
      "$py" - "$name" "$seed" "$out" <<'PY'
import json, sys
name, seed, path = sys.argv[1], sys.argv[2], sys.argv[3]
j = json.loads(open(path).readline())
c = j.get("compliant", {})
print(",".join(str(x) for x in [name, seed, round(j["wall_seconds"], 4), j["events"], j["collisions"], j["bonds"],
      round(c.get("sundials_seconds", 0.0), 4), c.get("slices", 0), c.get("slice_cuts", 0), c.get("relaxed", 0),
      c.get("bursts", 0), j["termination"]]))
PY
    else
      echo "$name,$seed,>$limit,,,,,,,,,timeout"
    fi
  done
done | tee "$out.csv"
"$py" - "$out.csv" <<'PY'
import csv, statistics, sys
rows = list(csv.reader(open(sys.argv[1])))
def walls(prefix):
    return [float(r[2]) for r in rows if r[0].startswith(prefix) and not r[2].startswith(">")]
w4, w5 = walls("4-"), walls("5-")
timeouts = sum(1 for r in rows if r[2].startswith(">"))
s5 = [(float(r[6]), float(r[2])) for r in rows if r[0].startswith("5-") and not r[2].startswith(">")]
if w4 and w5:
    m4, m5 = statistics.median(w4), statistics.median(w5)
    share = statistics.median(s / w for s, w in s5) if s5 else float("nan")
    print(f"# median wall: scenario 4 {m4:.3f} s, scenario 5 {m5:.3f} s, ratio {m5 / m4:.2f}; "
          f"SUNDIALS share of scenario 5 (median) {100 * share:.1f} %; timeouts {timeouts}")
PY
rm -f "$out.csv"
