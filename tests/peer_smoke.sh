#!/usr/bin/env bash
# The Bullet peer (bench/peer, docs/PEER.md) at tiny size: it starts from
# ringsim's scene (same packing and mixing for the same seed), prints the
# fields of `ringsim replicate --json`, keeps an elastic gas's energy at a
# small step, forms welded and articulated bonds (Scenario 4's filters
# included: held angles and dihedrals), and refuses what it does not model.
# Usage: peer_smoke.sh RINGSIM_PEER RINGSIM
set -uo pipefail
PEER=$1
RINGSIM=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
small=(--seed 3 --set init.spheres=30 --set init.linkers=30 --set geometry.box_length=20)

"$PEER" "${small[@]}" --set bonding.enabled=false --set run.t_max=5 --dt 0.005 > "$tmp/gas.json" ||
  fail "gas run exited $?"
"$RINGSIM" replicate "${small[@]}" --set bonding.enabled=false --set run.t_max=5 --json > "$tmp/gas_ref.json" ||
  fail "ringsim gas run exited $?"
"$PEER" "${small[@]}" --set bonding.capture_distance=0.5 --set bonding.angle_filter=false \
  --set bonding.coplanarity_filter=false --set run.t_max=20 --dt 0.01 --set bonding.joint=welded > "$tmp/bond.json" ||
  fail "bonding run exited $?"
"$PEER" "${small[@]}" --set bonding.capture_distance=0.5 --set bonding.angle_filter=false \
  --set bonding.coplanarity_filter=false --set run.t_max=20 --dt 0.01 --set bonding.joint=articulated > "$tmp/art.json" ||
  fail "articulated bonding run exited $?"
# Scenario 4 articulated (both filters: held angles and dihedrals), its
# windows widened from 5 to 20 degrees so that a run this small holds some
# dihedrals (this seed: 1 by t = 30, in about a second).
"$PEER" "$(dirname "$0")/../jobs/scenarios/4-passive-selection.toml" "${small[@]}" --set bonding.capture_distance=0.5 \
  --set bonding.dtheta_deg=20 --set bonding.dphi_deg=20 --set run.t_max=30 --dt 0.01 --set bonding.joint=articulated \
  > "$tmp/s4.json" || fail "Scenario 4 articulated run exited $?"

/usr/bin/python3 - "$tmp" <<'PY' || exit 1
import json, sys
d = sys.argv[1]
gas = json.load(open(f"{d}/gas.json"))
ref = json.load(open(f"{d}/gas_ref.json"))
bond = json.load(open(f"{d}/bond.json"))
art = json.load(open(f"{d}/art.json"))
s4 = json.load(open(f"{d}/s4.json"))
def check(ok, what):
    if not ok:
        print("FAIL:", what, file=sys.stderr)
        sys.exit(1)
shared = ["seed", "spheres", "linkers", "packing_fraction", "mixing", "events", "collisions", "wall_collisions",
          "t_end", "termination", "wall_seconds", "energy", "momentum", "captures", "bonds", "rejected", "N_t",
          "N_tar", "N_viab", "N_cyc", "rings", "Phi_obj", "Phi_viab", "S4", "M_mono", "M_mono_S", "M_mono_L",
          "tau_tar", "tau_tar_censored"]
for k in shared:
    check(k in ref, f"ringsim has no field {k} (update the list)")
    check(k in gas and k in bond and k in art, f"peer has no field {k}")
check(gas["packing_fraction"] == ref["packing_fraction"] and gas["mixing"] == ref["mixing"],
      "the peer's scene is not ringsim's")
check(gas["termination"] == "t_max" and gas["t_end"] == 5.0, f"gas ended {gas['termination']} at {gas['t_end']}")
e0 = ref["energy_budget"]["initial"]
check(abs(gas["peer"]["energy_drift"]) < 0.05, f"gas energy drift {gas['peer']['energy_drift']}")
check(abs(gas["energy_budget"]["initial"] / e0 - 1) < 1e-5, "the peer's initial energy is not ringsim's")
check(gas["collisions"] > 0 and gas["wall_collisions"] > 0, "no collisions in the gas")
check(bond["bonds"] > 0 and bond["peer"]["bond_constraints"] == bond["bonds"], f"bonds {bond['bonds']}")
check(bond["N_t"] == 60 - bond["bonds"] + bond["N_cyc"] + sum(v for m, v in bond["rings"].items() if int(m) < 3),
      "N_t does not match the bonds")
check(all(f in bond["peer"]["failures"] for f in ["non_finite", "escaped", "joint_drift"]), "failures not recorded")
# Articulated: ball joints, bonds inside clusters allowed, contacts by the exclusions.
ap = art["peer"]
check(ap["joint"] == "articulated", f"articulated run reports joint {ap['joint']}")
check(art["termination"] != "error", f"articulated run ended {art['termination']}")
check(art["bonds"] > 0 and ap["constraints"]["ball"] == art["bonds"] and ap["constraints"]["fixed"] == 0,
      f"articulated bonds {art['bonds']}, constraints {ap['constraints']}")
check(art["N_t"] == 60 - art["bonds"] + art["N_cyc"] + sum(v for m, v in art["rings"].items() if int(m) < 3),
      "articulated N_t does not match the bonds")
for f in ["non_finite", "escaped"]:
    check(ap["failures"][f]["count"] == 0, f"articulated run recorded {f}: {ap['failures'][f]}")
check(ap["failures"]["drift_capture"]["count"] == 0, "articulated run recorded a drift_capture")
# Scenario 4 articulated: held angles and dihedrals, the dihedrals held.
sp = s4["peer"]
check(s4["termination"] == "t_max", f"Scenario 4 articulated run ended {s4['termination']}")
check(sp["constraints"]["ball"] == s4["bonds"] and sp["constraints"]["held_angle"] > 0 and
      sp["constraints"]["held_dihedral"] > 0, f"Scenario 4 articulated constraints {sp['constraints']}")
check(s4["N_t"] == 60 - s4["bonds"] + s4["N_cyc"] + sum(v for m, v in s4["rings"].items() if int(m) < 3),
      "Scenario 4 articulated N_t does not match the bonds")
check(0 < sp["max_dihedral_drift_deg"] < 0.5 and sp["max_dihedral_residual"] < 0.01,
      f"held dihedrals drifted {sp['max_dihedral_drift_deg']} deg, |C| {sp['max_dihedral_residual']}")
check(sp["skipped_dihedral_rows"] == 0, f"{sp['skipped_dihedral_rows']} dihedral rows skipped by the solver")
for f in ["non_finite", "escaped", "joint_drift", "drift_capture"]:
    check(sp["failures"][f]["count"] == 0, f"Scenario 4 articulated run recorded {f}: {sp['failures'][f]}")
PY

"$PEER" "${small[@]}" --set bonding.joint=hinged --set run.t_max=1 > /dev/null 2>&1
[ $? = 1 ] || fail "an unknown joint reading is not refused"
"$PEER" "${small[@]}" --set geometry.boundary=periodic --set run.t_max=1 > /dev/null 2>&1
[ $? = 1 ] || fail "a periodic box is not refused"
echo "peer smoke test passed"
