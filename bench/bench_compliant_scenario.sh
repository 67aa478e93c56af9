#!/usr/bin/env bash
# Scenario 5 (compliant) against Scenario 4 (rigid): wall time per replicate
# over the same horizon, seeds alternating between the two scenarios so that
# machine noise hits both alike; the share of Scenario 5's time inside
# SUNDIALS. docs/COMPLIANT.md, "Coupling: cost".
#
# usage: bench/bench_compliant_scenario.sh RINGSIM T_MAX SEEDS [TIMEOUT_S] [JOBS]
#   e.g. bench/bench_compliant_scenario.sh ./build/ringsim 100 10
#        bench/bench_compliant_scenario.sh ./build/ringsim full 8 900 2
#   T_MAX  a horizon (steady-state stop off), or `full`: the replicate
#          protocol itself (MSER steady state or run.t_max = 5000)
#   JOBS   replicates run at once (default 1; rows in completion order)
# Prints one CSV row per replicate, then the medians and their ratio.
# Extra overrides for both scenarios: RINGSIM_SET="run.contact_tolerance=1e-6 ..."
set -euo pipefail
ringsim=${1:?ringsim binary}
t_max=${2:?t_max}
seeds=${3:?number of seeds}
limit=${4:-600}
jobs=${5:-1}
here=$(cd "$(dirname "$0")/.." && pwd)
py=/usr/bin/python3
out=$(mktemp)
trap 'rm -f "$out" "$out.csv"' EXIT
horizon=()
[[ $t_max != full ]] && horizon=(--set run.t_max="$t_max" --set run.steady_state=false)
extra=()
for kv in ${RINGSIM_SET:-}; do extra+=(--set "$kv"); done

# One replicate: scenario name and seed in, one CSV row out.
run_one() {
  local name=$1 seed=$2 json
  json=$(mktemp)
  if timeout "$limit" "$ringsim" replicate "$here/jobs/scenarios/$name.toml" --seed "$seed" "${horizon[@]}" \
      "${extra[@]}" --json > "$json" 2>/dev/null; then
    "$py" - "$name" "$seed" "$json" <<'PY'
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
  rm -f "$json"
}
export -f run_one
export ringsim here limit py
export horizon_flat="${horizon[*]:-}" extra_flat="${extra[*]:-}"

echo "scenario,seed,wall_s,events,collisions,bonds,sundials_s,slices,cuts,relaxed,bursts,termination"
for seed in $(seq 1 "$seeds"); do
  echo "4-passive-selection $seed"
  echo "5-compliant $seed"
done | xargs -P "$jobs" -L 1 bash -c 'horizon=($horizon_flat); extra=($extra_flat); run_one "$0" "$1"' | tee "$out.csv"
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
