#!/usr/bin/env bash
# Where the kinetic energy goes: the replicate's energy ledger
# (`energy_budget` in `ringsim replicate --json`, docs/OUTPUT.md) for a few
# seeds at several horizons, as CSV, then the mean of each term per horizon.
# docs/RESULTS.md, "Scenario 5: why the compliant box cools".
#
# usage: bench/energy_budget.sh RINGSIM SCENARIO SEEDS "T1 T2 ..." [JOBS]
#   e.g. bench/energy_budget.sh ./build/ringsim jobs/scenarios/5-compliant.toml 4 "250 1000 5000" 2
# Each horizon is a separate run with run.steady_state=false (a shorter run is
# the prefix of a longer one: replicates are deterministic). Extra overrides:
# RINGSIM_SET="compliant.relax_energy=0 ...".
set -euo pipefail
ringsim=${1:?ringsim binary}
scenario=${2:?scenario file}
seeds=${3:?number of seeds}
horizons=${4:?horizons}
jobs=${5:-1}
export ringsim scenario
export extra_flat="${RINGSIM_SET:-}"
out=$(mktemp)
trap 'rm -f "$out"' EXIT

run_one() {
  local t_max=$1 seed=$2 extra=()
  for kv in $extra_flat; do extra+=(--set "$kv"); done
  "$ringsim" replicate "$scenario" --seed "$seed" --set run.t_max="$t_max" --set run.steady_state=false \
    "${extra[@]}" --json | /usr/bin/python3 -c '
import json, sys
j = json.loads(sys.stdin.readline())
e = j["energy_budget"]
keys = ["initial", "bonds_in", "kinetic", "potential", "lost_contacts", "lost_rigid_merges", "lost_relaxed",
        "lost_bursts", "lost_dampers"]
print(",".join([sys.argv[1], sys.argv[2], str(j["bonds"]), str(round(j["wall_seconds"], 2))] +
               ["%.6g" % e[k] for k in keys]))' "$t_max" "$seed"
}
export -f run_one

echo "t_max,seed,bonds,wall_s,initial,bonds_in,kinetic,potential,lost_contacts,lost_rigid_merges,lost_relaxed,lost_bursts,lost_dampers"
for t in $horizons; do
  for seed in $(seq 1 "$seeds"); do echo "$t $seed"; done
done | xargs -P "$jobs" -L 1 bash -c 'run_one "$0" "$1"' | tee "$out"
/usr/bin/python3 - "$out" <<'PY'
import csv, sys
from collections import defaultdict
cols = ["bonds", "initial", "bonds_in", "kinetic", "potential", "lost_contacts", "lost_rigid_merges", "lost_relaxed",
        "lost_bursts", "lost_dampers"]
rows = defaultdict(list)
for r in csv.reader(open(sys.argv[1])):
    rows[float(r[0])].append([float(x) for x in [r[2]] + r[4:]])
print("# means per horizon: t_max, " + ", ".join(cols))
for t in sorted(rows):
    n = len(rows[t])
    print("# %g, " % t + ", ".join("%.4g" % (sum(r[k] for r in rows[t]) / n) for k in range(len(cols))) + "  (n = %d)" % n)
PY
