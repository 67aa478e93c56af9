#!/usr/bin/env bash
# Runs R replicates of each scenario with `ringsim replicate --json`, JOBS at a
# time, one JSON line per replicate in OUT/<scenario>.jsonl. Replicate r uses
# base seed SEED and replicate index r (the same streams as the ensemble
# runner will use), so any line can be reproduced on its own:
#   ringsim replicate jobs/scenarios/<scenario>.toml --seed SEED --replicate r --json
#
# Usage: bench/run_scenarios.sh RINGSIM OUT R [JOBS] [SEED] [SCENARIO...] [-- --set KEY=VALUE...]
#   RINGSIM   path of the ringsim binary
#   OUT       output directory (created)
#   R         replicates per scenario
#   JOBS      parallel processes (default: number of cores)
#   SEED      base seed (default 1)
#   SCENARIO  names under jobs/scenarios without .toml (default: 1-baseline
#             2-bond-angle 3-coplanarity 4-passive-selection)
# Anything after `--` is passed to every replicate (e.g. --set run.t_max=1000).
# Summarize with: /usr/bin/python3 bench/summarize_scenarios.py OUT
set -euo pipefail
if [[ $# -lt 3 ]]; then sed -n '2,19p' "$0"; exit 1; fi
bin=$1 out=$2 reps=$3
shift 3
jobs=$(nproc); seed=1
if [[ $# -gt 0 && $1 != -- ]]; then jobs=$1; shift; fi
if [[ $# -gt 0 && $1 != -- ]]; then seed=$1; shift; fi
scenarios=()
while [[ $# -gt 0 && $1 != -- ]]; do scenarios+=("$1"); shift; done
[[ $# -gt 0 && $1 == -- ]] && shift
extra=("$@")
[[ ${#scenarios[@]} -eq 0 ]] && scenarios=(1-baseline 2-bond-angle 3-coplanarity 4-passive-selection)
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
for s in "${scenarios[@]}"; do
  file="$here/jobs/scenarios/$s.toml"
  [[ -f $file ]] || { echo "run_scenarios: no scenario file $file" >&2; exit 1; }
  echo "scenario $s: $reps replicates, $jobs at a time" >&2
  seq 0 $((reps - 1)) | xargs -P "$jobs" -I{} sh -c \
    'b=$0 f=$1 s=$2 o=$3; shift 3; "$b" replicate "$f" --seed "$s" --replicate {} --json "$@" > "$o.{}.json"' \
    "$bin" "$file" "$seed" "$out/$s" "${extra[@]}" ||
    echo "run_scenarios: $s: some replicates ended in an error (their JSON says which: termination, error)" >&2
  for r in $(seq 0 $((reps - 1))); do cat "$out/$s.$r.json"; done > "$out/$s.jsonl"
  rm -f "$out/$s".*.json
done
