#!/usr/bin/python3
"""Chart of the compliant-integrator stability study (bench/bench_compliant.cpp).

Usage: bench/plot_compliant.py STUDY.csv OUT.png

Panels: right-hand-side evaluations, wall time and pose error at the end of
the span against the spring constant k = k_omega (c = c_omega = k/10) for
CVODE BDF, CVODE Adams and ARKODE ERK on the four-corner chain; a run that
failed is drawn as a red cross at the cost it had spent when it stopped,
labelled with the time it reached. Fourth panel: BDF wall time against the
number of unknowns of staircase chains, dense versus band linear solver.

With the Scenario 5 studies (`bench_compliant --studies scenario`) the first
three panels show the clusters recorded from a Scenario 5 replicate (summed
over them), the fourth the replicate's own wall time through the event loop
per method, with its runs at slices of 1 time unit (failures as red crosses).
"""

import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    ("bdf", "dense"): dict(label="CVODE BDF (dense DQ Jacobian)", color="tab:blue", marker="o"),
    ("adams", "none"): dict(label="CVODE Adams (fixed point)", color="tab:green", marker="s"),
    ("erk", "none"): dict(label="ARKODE ERK (Dormand-Prince 5(4))", color="tab:orange", marker="^"),
}


def main(path, out):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    scenario = any(r["study"] == "scenario" for r in rows)
    stiff = [r for r in rows if r["study"] == ("scenario" if scenario else "stiffness")]
    band = [r for r in rows if r["study"] == "bandwidth"]

    fig, axes = plt.subplots(2, 2, figsize=(11, 8.5))
    panels = [
        (axes[0][0], "rhs_evals", "right-hand-side evaluations", 1.0),
        (axes[0][1], "wall_seconds", "wall time [ms]", 1e3),
        (axes[1][0], "error", "max pose error at T vs reference", 1.0),
    ]
    for ax, column, ylabel, scale in panels:
        for (method, solver), style in STYLE.items():
            sel = [r for r in stiff if r["method"] == method and r["linear_solver"] == solver]
            ok = [r for r in sel if r["status"] == "ok"]
            bad = [r for r in sel if r["status"] != "ok"]
            ax.plot([float(r["k"]) for r in ok], [float(r[column]) * scale for r in ok], **style)
            if column == "error":
                continue
            for r in bad:
                x, y = float(r["k"]), float(r[column]) * scale
                ax.plot([x], [y], marker="x", color="red", markersize=11, mew=2.5, linestyle="none")
                ax.annotate(f"{method}: {r['status'].replace('_', ' ')}\nat t = {float(r['t_reached']):.2g} of 2",
                            (x, y), textcoords="offset points", xytext=(-105, -4 if method == "erk" else -22),
                            fontsize=7, color="red")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("k = k_omega  (c = c_omega = k/10)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=8, loc="upper left")
    axes[1][0].set_title("failed runs have no error point", fontsize=8)

    ax = axes[1][1]
    if scenario:
        replicate_panel(ax, rows)
        fig.suptitle("Clusters of a Scenario 5 replicate (seed 1, bonds in t <= 300; each integrated over T = 2) "
                     "and the replicate itself (t <= 10): cost against stiffness", fontsize=10)
        fig.tight_layout()
        fig.savefig(out, dpi=110)
        return
    for solver, color in (("dense", "tab:blue"), ("band", "tab:purple")):
        sel = [r for r in band if r["linear_solver"] == solver]
        ax.plot([int(r["unknowns"]) for r in sel], [float(r["wall_seconds"]) * 1e3 for r in sel], marker="o",
                color=color, label=f"BDF, {solver} DQ Jacobian")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("unknowns (staircase chains, k = k_omega = 1000)")
    ax.set_ylabel("wall time [ms]")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)

    span = "2"
    fig.suptitle(f"Compliant four-corner chain relaxing over T = {span}: cost against stiffness "
                 "(rtol 1e-6, atol 1e-8, cap 20000 steps)", fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def replicate_panel(ax, rows):
    for (method, solver), style in STYLE.items():
        sel = [r for r in rows if r["study"] == "replicate" and r["method"] == method]
        ax.plot([float(r["k"]) for r in sel], [float(r["wall_seconds"]) for r in sel], **style)
        for r in rows:
            if r["study"] != "replicate-slice1" or r["method"] != method:
                continue
            x, y = float(r["k"]), float(r["wall_seconds"])
            failed = r["status"] != "ok"
            ax.plot([x], [y], marker="x" if failed else style["marker"], color="red" if failed else style["color"],
                    markersize=11 if failed else 6, mew=2.5 if failed else 1, linestyle="none")
            if failed:
                ax.annotate(f"{method}, slices of 1: failed\nat t = {float(r['t_reached']):.3g}", (x, y),
                            textcoords="offset points", xytext=(-120, -4 if method == "erk" else -26), fontsize=7,
                            color="red")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("k = k_omega  (c = c_omega = k/10)")
    ax.set_ylabel("replicate wall time to t = 10 [s]")
    ax.grid(True, which="both", alpha=0.3)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
