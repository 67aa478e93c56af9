#!/usr/bin/python3
"""Cost of one replicate against system size at a fixed box (issue 6).

N_S = N_L = N for each N in --sizes, in the default 50 box (Scenario 4's
rules), so N and the packing fraction grow together: 150 -> 0.020,
300 -> 0.040 (the study's default), ..., 2400 -> 0.32. Each size runs R
seeded replicates over the same simulated time --t-max (the full protocol
at N = 2400 would take hours; the early phase is where the cost per time
unit is highest, since bonding and collisions are fastest there), JOBS at a
time. Reported per size (medians over replicates): wall seconds, events,
collisions, bonds, wall seconds per simulated time unit and microseconds per
event and per collision. Output in OUT: runs/N<N>__t<t_max>.jsonl (reused when complete),
scaling.csv and scaling.png (log-log, with the slopes of the cost per time
unit, per event and per collision against N).

Usage:
  /usr/bin/python3 bench/scaling.py --ringsim build/ringsim --out OUT
      [--sizes 150,300,600,1200,2400] [-R 3] [--jobs 2] [--seed 1] [--t-max 20]
"""
import argparse
import concurrent.futures as cf
import csv
import math
import pathlib
import statistics
import sys

import numpy as np

from replicate_runner import run_cached


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ringsim", default="build/ringsim")
    ap.add_argument("--out", required=True, type=pathlib.Path)
    ap.add_argument("--sizes", default="150,300,600,1200,2400")
    ap.add_argument("-R", "--replicates", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--t-max", type=float, default=20.0)
    a = ap.parse_args()
    try:
        sizes = [int(s) for s in a.sizes.split(",") if s.strip()]
    except ValueError:
        sys.exit(f"scaling: --sizes = {a.sizes!r}: must be a comma list of integers >= 1")
    if not sizes or min(sizes) < 1:
        sys.exit(f"scaling: --sizes = {a.sizes!r}: must be a comma list of integers >= 1")
    if a.replicates < 1:
        sys.exit(f"scaling: --replicates = {a.replicates}: must be >= 1")
    if a.jobs < 1:
        sys.exit(f"scaling: --jobs = {a.jobs}: must be >= 1")
    if not (a.t_max > 0 and math.isfinite(a.t_max)):
        sys.exit(f"scaling: --t-max = {a.t_max}: must be a finite number > 0")
    rows = []
    with cf.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        for n in sizes:
            sets = {"init.spheres": n, "init.linkers": n, "run.t_max": a.t_max}
            got = run_cached(pool, a.out / "runs" / f"N{n}__t{a.t_max:g}.jsonl", a.ringsim, None,
                             a.seed, a.replicates, sets)
            med = lambda key: statistics.median(r[key] for r in got)
            row = {"N_per_species": n, "bodies": 2 * n, "packing_fraction": got[0]["packing_fraction"],
                   "R": len(got), "t_max": a.t_max,
                   "median_wall_s": med("wall_seconds"), "median_events": med("events"),
                   "median_collisions": med("collisions"), "median_bonds": med("bonds"),
                   "median_t_end": med("t_end")}
            row["wall_s_per_time_unit"] = statistics.median(r["wall_seconds"] / r["t_end"] for r in got)
            row["us_per_event"] = statistics.median(1e6 * r["wall_seconds"] / r["events"] for r in got)
            row["us_per_collision"] = statistics.median(1e6 * r["wall_seconds"] / max(r["collisions"], 1)
                                                        for r in got)
            rows.append(row)
            print(f"N = {n}: median wall {row['median_wall_s']:.2f} s, {row['median_events']:.0f} events, "
                  f"{row['us_per_event']:.1f} us/event", file=sys.stderr, flush=True)
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "scaling.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    plot(rows, a.out / "scaling.png")
    print(f"wrote {a.out / 'scaling.csv'} and {a.out / 'scaling.png'}", file=sys.stderr)


def slope(x, y):
    return float(np.polyfit(np.log(x), np.log(y), 1)[0]) if len(x) > 1 else float("nan")


def plot(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = np.array([r["N_per_species"] for r in rows], float)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.3))
    series = [("wall_s_per_time_unit", "wall s per time unit"), ("median_events", "events"),
              ("median_collisions", "collisions"), ("median_bonds", "bonds")]
    for key, label in series:
        y = np.array([r[key] for r in rows], float)
        if key != "wall_s_per_time_unit":
            y = y / rows[0]["t_max"]
            label += " per time unit"
        ok = y > 0
        ax[0].loglog(n[ok], y[ok], "o-", label=f"{label} (slope {slope(n[ok], y[ok]):.2f})")
    ax[0].set_xlabel("N_S = N_L (box 50)")
    ax[0].set_title(f"rates over t = 0 … {rows[0]['t_max']:g}, median of {rows[0]['R']}", fontsize=10)
    ax[0].legend(fontsize=8)
    us = np.array([r["us_per_event"] for r in rows], float)
    ax[1].loglog(n, us, "o-", color="C4", label=f"µs per event (slope {slope(n, us):.2f})")
    uc = np.array([r["us_per_collision"] for r in rows], float)
    ax[1].loglog(n, uc, "s-", color="C2", label=f"µs per collision (slope {slope(n, uc):.2f})")
    for r in rows:
        ax[1].annotate(f"φ = {r['packing_fraction']:.3f}", (r["N_per_species"], r["us_per_event"]),
                       fontsize=8, xytext=(4, -10), textcoords="offset points")
    ax[1].set_xlabel("N_S = N_L (box 50)")
    ax[1].set_ylabel("wall µs")
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
