#!/usr/bin/python3
"""Compare two ensemble result files replicate by replicate.

Usage: scripts/compare_runs.py BASE.h5 OTHER.h5 [KEY ...]

Both files must come from the same base seed (replicate r uses the random
streams keyed by (seed, r), so equal ids start from the same scene). Prints,
for each observable (default: N_t, M_mono, M_mono_S, M_mono_L, bonds, N_cyc,
Phi_viab), each file's mean ± 95 % CI (Student t), whether BASE's mean lies
inside OTHER's CI, and the paired difference OTHER - BASE with its 95 % CI;
then the median wall time per replicate of each and the median of the paired
ratios OTHER / BASE. Used for docs/COMPLIANT.md, "Relaxed switch against the
always-integrated run".
"""

import sys

import h5py
import numpy as np
from scipy import stats


def load(path):
    with h5py.File(path, "r") as f:
        rows = f["replicates"][()]
        seed = f.attrs["base_seed"]
    rows = rows[rows["status"] == 1]  # finished replicates only
    return rows[np.argsort(rows["id"])], seed


def ci(x):
    x = np.asarray(x, float)
    if len(x) < 2:
        return x.mean(), float("nan")
    return x.mean(), stats.t.ppf(0.975, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x))


def main(base_path, other_path, keys):
    base, seed_a = load(base_path)
    other, seed_b = load(other_path)
    if seed_a != seed_b:
        sys.exit(f"base seeds differ ({seed_a} vs {seed_b}): replicates cannot be paired")
    ids = np.intersect1d(base["id"], other["id"])
    a = base[np.isin(base["id"], ids)]
    b = other[np.isin(other["id"], ids)]
    fields = base.dtype.names
    for k in keys:
        if k not in fields:
            sys.exit(f"observable {k!r} is not a column of {base_path} (valid: {', '.join(fields)})")
    print(f"{len(base)} and {len(other)} finished replicates, {len(ids)} paired")
    for k in keys:
        ma, ha = ci(base[k])
        mb, hb = ci(other[k])
        inside = abs(ma - mb) <= hb if hb > 0 else ma == mb
        md, hd = ci(b[k].astype(float) - a[k].astype(float))
        print(f"{k:9s} base {ma:.5g} ± {ha:.2g} | other {mb:.5g} ± {hb:.2g} | base mean inside other's CI: "
              f"{'yes' if inside else 'NO'} | paired difference {md:.3g} ± {hd:.2g}")
    wa, wb = np.median(base["wall_seconds"]), np.median(other["wall_seconds"])
    ratio = np.median(b["wall_seconds"] / a["wall_seconds"])
    print(f"median wall per replicate: base {wa:.1f} s, other {wb:.1f} s; median paired ratio other/base {ratio:.2f}")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2],
         sys.argv[3:] or ["N_t", "M_mono", "M_mono_S", "M_mono_L", "bonds", "N_cyc", "Phi_viab"])
