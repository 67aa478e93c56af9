#!/usr/bin/python3
"""Chart of the energy ledger over time (bench/energy_budget.sh output).

Usage: bench/plot_energy_budget.py OUT.png LABEL=CSV [LABEL=CSV ...]

Each CSV holds replicates of one scenario at several horizons (a shorter run
is the prefix of a longer one). Panels, means over the seeds at each horizon:
kinetic energy; bonds formed; the cumulative energy flows (what compliant
bonds brought in, what the dampers, the rigid merges and the switches to
rigid motion took out). docs/RESULTS.md, "Scenario 5: why the compliant box
cools".
"""

import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FLOWS = [("bonds_in", "brought in by compliant bonds", "-"),
         ("lost_dampers", "taken by the dampers (rest)", "--"),
         ("lost_rigid_merges", "taken by rigid merges", "-."),
         ("lost_switches", "taken by relaxed + burst switches", ":")]


def means(path):
    by_t = defaultdict(list)
    with open(path, newline="") as f:
        for r in csv.DictReader(line for line in f if not line.startswith("#")):
            r = {k: float(v) for k, v in r.items() if k not in ("seed",)}
            r["lost_switches"] = r["lost_relaxed"] + r["lost_bursts"]
            by_t[r["t_max"]].append(r)
    ts = sorted(by_t)
    out = {"t": [0.0] + ts}
    for key in ["kinetic", "bonds", "bonds_in", "lost_dampers", "lost_rigid_merges", "lost_switches"]:
        first = sum(r["initial"] for r in by_t[ts[0]]) / len(by_t[ts[0]]) if key == "kinetic" else 0.0
        out[key] = [first] + [sum(r[key] for r in by_t[t]) / len(by_t[t]) for t in ts]
    out["n"] = min(len(v) for v in by_t.values())
    return out


def main(out, pairs):
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple"]
    for (label, path), color in zip(pairs, colors):
        m = means(path)
        name = f"{label} (n = {m['n']})"
        axes[0].plot(m["t"], m["kinetic"], "o-", color=color, label=name)
        axes[1].plot(m["t"], m["bonds"], "o-", color=color, label=name)
        for key, text, style in FLOWS:
            if max(abs(v) for v in m[key]) > 1e-6 * m["kinetic"][0]:
                axes[2].plot(m["t"], m[key], style, marker="o", ms=3, color=color, label=f"{label}: {text}")
    axes[0].set_ylabel("kinetic energy")
    axes[1].set_ylabel("bonds formed")
    axes[2].set_ylabel("cumulative energy")
    for ax in axes:
        ax.set_xlabel("time")
        ax.set_xscale("symlog", linthresh=100)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[2].legend(fontsize=7)
    fig.suptitle("Energy ledger (replicate JSON energy_budget), means over seeds")
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    pairs = []
    for arg in sys.argv[2:]:
        if "=" not in arg:
            sys.exit(f"{arg!r}: expected LABEL=CSV (e.g. 'Scenario 5=s5.csv')")
        pairs.append(arg.split("=", 1))
    main(sys.argv[1], pairs)
