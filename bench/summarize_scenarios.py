#!/usr/bin/python3
"""Summarize bench/run_scenarios.sh output: per scenario, the study's
observables as mean +- 95 % CI (Student t) over replicates, with the counts
of undefined (S4 without rings) and censored (tau_tar) values, and the
performance of one replicate (median wall time, events per second).

Usage: /usr/bin/python3 bench/summarize_scenarios.py OUT [--format markdown|csv]
"""
import argparse
import json
import math
import pathlib
import statistics
import sys

from scipy import stats


def mean_ci(values):
    vals = [v for v in values if v is not None and math.isfinite(v)]
    n = len(vals)
    if n == 0:
        return float("nan"), float("nan"), 0
    m = statistics.fmean(vals)
    if n < 2:
        return m, float("nan"), n
    half = stats.t.ppf(0.975, n - 1) * statistics.stdev(vals) / math.sqrt(n)
    return m, half, n


def fmt(m, h, digits=3):
    if math.isnan(m):
        return "undefined"
    return f"{m:.{digits}g} ± {h:.2g}" if not math.isnan(h) else f"{m:.{digits}g}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--format", choices=["markdown", "csv"], default="markdown")
    a = ap.parse_args()
    files = sorted(pathlib.Path(a.out).glob("*.jsonl"))
    if not files:
        sys.exit(f"summarize_scenarios: no *.jsonl files in {a.out}")
    rows = []
    for f in files:
        reps = [json.loads(line) for line in f.read_text().splitlines() if line.strip()]
        ok = [r for r in reps if r["termination"] != "error"]
        row = {"scenario": f.stem, "R": len(reps), "failed": len(reps) - len(ok)}
        for key in ["N_t", "N_tar", "Phi_obj", "Phi_viab", "M_mono", "N_cyc"]:
            row[key] = mean_ci([r[key] for r in ok])
        row["S4"] = mean_ci([r["S4"] for r in ok])
        row["S4_undefined"] = sum(1 for r in ok if r["S4"] is None)
        row["tau_tar"] = mean_ci([r["tau_tar"] for r in ok])
        row["tau_censored"] = sum(1 for r in ok if r["tau_tar_censored"])
        rings = {}
        for r in ok:
            for m, c in r["rings"].items():
                rings[int(m)] = rings.get(int(m), 0) + c
        row["rings"] = " ".join(f"{m}:{rings[m]}" for m in sorted(rings))
        row["t_end"] = mean_ci([r["t_end"] for r in ok])
        term = {}
        for r in ok:
            term[r["termination"]] = term.get(r["termination"], 0) + 1
        row["termination"] = ", ".join(f"{k} {v}" for k, v in sorted(term.items()))
        # Articulated bonds: clusters standing at the end, rigid or integrated
        # (replicate --json's articulated.clusters_at_end), and the released rows.
        share = [r["articulated"]["clusters_at_end"] for r in ok if "clusters_at_end" in r.get("articulated", {})]
        if share:
            for k in ["rigid", "rigid_bodies", "articulated", "articulated_bodies"]:
                row["end_" + k] = mean_ci([x[k] for x in share])
            row["max_released"] = max(r["articulated"]["max_released_residual"] for r in ok)
        row["wall_median"] = statistics.median(r["wall_seconds"] for r in reps)
        row["events_per_s"] = statistics.median(r["events_per_second"] for r in reps)
        rows.append(row)
    if a.format == "csv":
        keys = list(rows[0].keys())
        print(",".join(keys))
        for row in rows:
            print(",".join(f'"{v}"' if isinstance(v, str) else
                           (f"{v[0]}±{v[1]}" if isinstance(v, tuple) else str(v)) for v in row.values()))
        return
    print("| scenario | R | N_t | N_tar | Phi_obj | Phi_viab | S4 (undef.) | M_mono | tau_tar (cens.) | rings m:count | end |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scenario']} | {r['R']} | {fmt(*r['N_t'][:2])} | {fmt(*r['N_tar'][:2])} | {fmt(*r['Phi_obj'][:2])} | "
              f"{fmt(*r['Phi_viab'][:2])} | {fmt(*r['S4'][:2])} ({r['S4_undefined']}) | {fmt(*r['M_mono'][:2])} | "
              f"{fmt(*r['tau_tar'][:2])} ({r['tau_censored']}) | {r['rings']} | {r['termination']} |")
    print()
    print("| scenario | median wall s / replicate | median events/s | mean t_end | failed |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scenario']} | {r['wall_median']:.3g} | {r['events_per_s']:.3g} | {fmt(*r['t_end'][:2])} | {r['failed']} |")
    shared = [r for r in rows if "end_rigid" in r]
    if shared:
        print()
        print("| scenario | rigid clusters at end (bodies) | articulated clusters at end (bodies) | rigid share of clustered bodies | largest stray of a released row |")
        print("|---|---|---|---|---|")
        for r in shared:
            rb, ab = r["end_rigid_bodies"][0], r["end_articulated_bodies"][0]
            print(f"| {r['scenario']} | {fmt(*r['end_rigid'][:2])} ({fmt(*r['end_rigid_bodies'][:2])}) | "
                  f"{fmt(*r['end_articulated'][:2])} ({fmt(*r['end_articulated_bodies'][:2])}) | "
                  f"{rb / (rb + ab):.3g} | {r['max_released']:.2g} |")


if __name__ == "__main__":
    main()
