#!/usr/bin/env bash
# The result file is readable with h5py and pandas exactly as docs/OUTPUT.md
# shows (Debian's /usr/bin/python3 with python3-h5py and python3-pandas).
set -euo pipefail
RINGSIM=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$RINGSIM" run --replicates 3 --seed 4 --series --set init.spheres=60 --set init.linkers=60 \
  --set geometry.box_length=25 --set run.t_max=25 -o "$tmp/r.h5" > /dev/null 2>&1
/usr/bin/python3 - "$tmp/r.h5" <<'PY'
import sys
import h5py
import numpy as np
import pandas as pd

with h5py.File(sys.argv[1], "r") as f:
    attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    for key in ["program", "version", "config_toml", "config_hash", "base_seed", "replicates", "ranks",
                "host", "start_time", "end_time", "complete"]:
        assert key in attrs, f"missing provenance attribute {key}"
    assert attrs["program"] == "ringsim" and attrs["replicates"] == 3 and attrs["complete"] == 1
    df = pd.DataFrame(f["replicates"][()])
    summary = pd.DataFrame(f["summary"][()])
    series = f["series/N_t"][()]
    n_ok = int(f["summary"].attrs["n_ok"])

assert len(df) == 3, len(df)
for col in ["id", "seed", "status", "termination", "t_end", "events", "wall_seconds", "N_t", "N_tar",
            "N_viab", "Phi_obj", "S4", "M_mono", "tau_tar", "tau_tar_censored", "ring_3", "ring_4",
            "ring_12", "ring_over"]:
    assert col in df.columns, f"missing column {col}"
assert list(df["id"]) == [0, 1, 2]
assert (df["status"] == 1).all()
assert set(df["termination"].str.decode("ascii")) <= {"t_max", "steady_state", "no_bond_possible"}
# S4 is NaN exactly where there is no ring.
assert (np.isnan(df["S4"]) == (df["N_cyc"] == 0)).all()
names = list(summary["name"].str.decode("ascii"))
assert "N_t" in names and "tau_tar" in names and "S4" in names
row = summary[summary["name"] == b"N_t"].iloc[0]
assert abs(row["mean"] - df["N_t"].mean()) < 1e-9, (row["mean"], df["N_t"].mean())
assert n_ok == 3
assert series.shape[0] == 3
# The series starts at t = 0 with at most every body its own object (pairs
# placed inside a capture shell bond at t = 0) and never rises.
assert 110 <= series[0, 0] <= 120, series[0, :3]
finite = series[0][np.isfinite(series[0])]
assert (np.diff(finite) <= 0).all(), finite
print("h5py/pandas read OK:", len(df), "rows,", len(names), "summary rows, series", series.shape)
PY
