#!/usr/bin/env bash
# Where the time-stepped peer fails (issue 35, docs/PEER.md): one replicate
# per row, the failure modes the peer records in its JSON ("peer.failures")
# and the errors they cause, as a markdown table.
#   - the hard-body gas (bonding off) to T = 100 at steps beyond the chart's
#     range, and at dt = 0.01 with Bullet's stock contact settings;
#   - Scenario 4 with welded bonds to T = 100 at large steps.
# Usage: bench/peer_failures.sh PEER [SEED] [T]
set -euo pipefail
PEER=$1
SEED=${2:-1}
T=${3:-100}
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
row() {  # label, then the peer's arguments
  local label=$1
  shift
  local json rc=0
  json=$("$PEER" --seed "$SEED" --set run.t_max="$T" "$@") || rc=$?
  PEER_JSON=$json /usr/bin/python3 - "$label" "$rc" <<'PY'
import json, os, sys
label, rc = sys.argv[1], sys.argv[2]
j = json.loads(os.environ["PEER_JSON"])
p = j["peer"]
fails = ", ".join("{} {} (first t = {:.4g})".format(k, v["count"], v["first_t"])
                  for k, v in p["failures"].items() if v["count"])
print("| {} | {} (exit {}) | {:+.3g} | {:.3g} | {} | {} | {:.3g} / {:.3g} | {} | {:.1f} |".format(
    label, j["termination"], rc, p["energy_drift"], p["max_penetration"], j["collisions"], j["bonds"],
    p["max_bond_drift"], p["max_bond_angle_drift_deg"], fails or "none", j["wall_seconds"]))
PY
}
echo "| run (seed $SEED, T = $T) | termination | energy drift | max penetration | collisions | bonds | bond drift (length / deg) | failures recorded | wall s |"
echo "|---|---|---|---|---|---|---|---|---|"
gas=(--set bonding.enabled=false)
for dt in 0.1 0.2 0.5; do row "gas, dt = $dt" "${gas[@]}" --dt "$dt"; done
row "gas, dt = 0.01, Bullet's stock contact settings" "${gas[@]}" --dt 0.01 --bullet-defaults
s4="$repo/jobs/scenarios/4-passive-selection.toml"
for dt in 0.05 0.1 0.2; do row "Scenario 4 welded, dt = $dt" "$s4" --dt "$dt" --set bonding.joint=welded; done
