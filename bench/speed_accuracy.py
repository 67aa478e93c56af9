#!/usr/bin/python3
"""Speed against accuracy for Scenarios 4 and 5 (issue 6, docs/PERFORMANCE.md).

For each accuracy knob of the simulator, each value in its list is run as R
replicates (`ringsim replicate SCENARIO --seed S --replicate r --json`, the
other knobs at their defaults), and so is a high-accuracy reference (every
knob at its accurate end). Replicate r of every setting starts from the same
scene (the random streams are keyed by seed and r), so each observable's
deviation from the reference is estimated from paired differences, mean and
95 % CI (Student t); so is its deviation from the default setting (columns
*_vs_default: the knob's own effect, free of the reference's sampling
error, which every *_dev column shares). Cost is the median wall time per replicate
(`wall_seconds`, set-up included), JOBS replicates running at once.
Replicates that end in a simulation error are counted (column `failed`)
and left out of the medians and of the paired differences.

Output in OUT: one JSON line per replicate (runs/<scenario>__t<t_max>__<overrides>.jsonl,
shared by identical settings, reused when complete, so an interrupted run resumes), speed_accuracy.csv
(one row per setting) and speed_accuracy.png (median wall time against the
deviation of N_t and M_mono, one curve per knob, defaults marked).

Usage:
  /usr/bin/python3 bench/speed_accuracy.py --ringsim build/ringsim --out OUT
      [-R 8] [--jobs 2] [--seed 1] [--scenarios 4,5] [--t-max-4 1000]
      [--t-max-5 200] [--knobs NAME,...] [--plot-only]

A chaotic event-driven run decorrelates from its reference within tens of
time units, so what a knob can change is the *distribution* of the
observables; a deviation inside its CI means no effect was resolved at this R.
"""
import argparse
import concurrent.futures as cf
import csv
import math
import pathlib
import statistics
import sys

from replicate_runner import run_cached
from summarize_scenarios import mean_ci

OBSERVABLES = ["N_t", "N_tar", "M_mono", "bonds", "Phi_viab"]


def knob_table():
    """Per scenario: the reference overrides and the knobs.

    A knob is (name, [(label, {key: value}), ...], default label). The
    reference sits at the accurate end of every knob at once (where the
    end itself runs: S4 at contact tolerance 1e-11 has failed searches, so
    its reference uses 1e-10)."""
    tol = [("1e-11", 1e-11), ("1e-10", 1e-10), ("1e-9", 1e-9), ("1e-8", 1e-8),
           ("1e-7", 1e-7), ("1e-6", 1e-6), ("1e-5", 1e-5), ("1e-4", 1e-4)]
    s4 = {
        "reference": {"run.contact_tolerance": 1e-10, "run.steady_state": "false"},
        "knobs": [
            ("contact_tolerance",
             [(lab, {"run.contact_tolerance": v}) for lab, v in tol], "1e-9"),
            ("mser_vs_fixed_t_max",
             [("fixed", {"run.steady_state": "false"}),
              ("mser-1", {"run.mser_batch": 1}),
              ("mser-5", {}),
              ("mser-20-min100", {"run.mser_batch": 20, "run.mser_min_samples": 100}),
              ("mser-5-min100-every10", {"run.mser_min_samples": 100, "run.mser_check_every": 10})],
             "mser-5"),
        ],
    }
    rtol = [("1e-8", 1e-8), ("1e-7", 1e-7), ("1e-6", 1e-6), ("1e-5", 1e-5),
            ("1e-4", 1e-4), ("1e-3", 1e-3)]
    s5 = {
        "reference": {"compliant.rtol": 1e-8, "compliant.atol": 1e-10,
                      "compliant.relax_energy": 0, "compliant.burst_contacts": 0,
                      "compliant.slice": 0.02, "run.steady_state": "false"},
        "knobs": [
            ("cvode_rtol (atol = rtol/100)",
             [(lab, {"compliant.rtol": v, "compliant.atol": v / 100}) for lab, v in rtol], "1e-6"),
            ("relax_energy",
             [(lab, {"compliant.relax_energy": v}) for lab, v in
              [("0", 0), ("1e-5", 1e-5), ("1e-4", 1e-4), ("1e-3", 1e-3), ("1e-2", 1e-2)]], "1e-4"),
            ("burst_contacts",
             [(lab, {"compliant.burst_contacts": v}) for lab, v in
              [("0", 0), ("16", 16), ("8", 8), ("4", 4)]], "8"),
            ("slice",
             [(lab, {"compliant.slice": v}) for lab, v in
              [("0.01", 0.01), ("0.02", 0.02), ("0.05", 0.05), ("0.2", 0.2)]], "0.05"),
            ("contact_tolerance",
             [(lab, {"run.contact_tolerance": v}) for lab, v in
              [("1e-10", 1e-10), ("1e-9", 1e-9), ("1e-8", 1e-8), ("1e-7", 1e-7), ("1e-6", 1e-6)]], "1e-9"),
            ("mser_vs_fixed_t_max",
             [("fixed", {"run.steady_state": "false"}), ("mser-5", {})], "mser-5"),
        ],
    }
    return {"4": ("4-passive-selection", s4), "5": ("5-compliant", s5)}


def ok(row):
    return row["termination"] != "error"


def paired(base, rows, key):
    """Mean and 95 % CI half-width of rows[key] - base[key], paired by
    replicate, over the pairs where both finished and the value is defined."""
    d = [r[key] - q[key] for r, q in zip(rows, base)
         if ok(r) and ok(q) and r.get(key) is not None and q.get(key) is not None]
    m, half, _ = mean_ci(d)
    return m, half


def summarize(scen, knob, label, is_default, rows, ref, default, t_max):
    """One CSV row. Failed replicates are counted and left out of every
    other column (all failed: NaN)."""
    good = [r for r in rows if ok(r)]
    nan = float("nan")
    median = lambda vals: statistics.median(vals) if vals else nan
    row = {"scenario": scen, "knob": knob, "value": label, "default": int(is_default),
           "R": len(rows), "t_max": t_max,
           "median_wall_s": median([r["wall_seconds"] for r in good]),
           "median_events": median([r["events"] for r in good]),
           "failed": len(rows) - len(good)}
    for key in OBSERVABLES:
        row[f"{key}_mean"] = mean_ci([r[key] for r in good])[0]
        for col, base in (("dev", ref), ("vs_default", default)):
            row[f"{key}_{col}"], row[f"{key}_{col}_ci"] = paired(base, rows, key)
    return row


def plot(rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scens = sorted({r["scenario"] for r in rows})
    panels = [("N_t", 1.0, "N_t - N_t(reference)"), ("M_mono", 100.0, "M_mono - M_mono(reference), % points")]
    fig, axes = plt.subplots(len(panels), len(scens), figsize=(6.2 * len(scens), 4.6 * len(panels)),
                             squeeze=False)
    for j, scen in enumerate(scens):
        srows = [r for r in rows if r["scenario"] == scen]
        knobs = [k for k in dict.fromkeys(r["knob"] for r in srows) if k != "reference"]
        ref = next(r for r in srows if r["knob"] == "reference")
        for i, (key, scale, ylabel) in enumerate(panels):
            ax = axes[i][j]
            ax.axhline(0, color="0.6", lw=0.8)
            ax.plot([ref["median_wall_s"]], [0], "kD", ms=7, label="reference")
            for n, knob in enumerate(knobs):
                kr = [r for r in srows if r["knob"] == knob]
                x = [r["median_wall_s"] for r in kr]
                y = [scale * r[f"{key}_dev"] for r in kr]
                e = [scale * r[f"{key}_dev_ci"] for r in kr]
                c = f"C{n}"
                ax.errorbar(x, y, yerr=e, color=c, marker="o", ms=4, capsize=3, lw=1, label=knob)
                for r in kr:
                    tag = r["value"] + (f" ({int(r['failed'])} failed)" if r["failed"] else "")
                    ax.annotate(tag, (r["median_wall_s"], scale * r[f"{key}_dev"]), fontsize=7,
                                xytext=(3, 3), textcoords="offset points", color=c)
                    if r["default"]:
                        ax.plot([r["median_wall_s"]], [scale * r[f"{key}_dev"]], "*", color=c, ms=15,
                                mec="k")
            ax.set_xscale("log")
            ax.set_xlabel("median wall time per replicate (s)")
            ax.set_ylabel(ylabel + " (paired, 95 % CI)")
            ax.set_title(f"Scenario {scen}, t_max = {ref['t_max']:g}, R = {ref['R']} (star: default)",
                         fontsize=10)
            if i == 0:
                ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ringsim", default="build/ringsim")
    ap.add_argument("--out", required=True, type=pathlib.Path)
    ap.add_argument("-R", "--replicates", type=int, default=8)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scenarios", default="4,5")
    ap.add_argument("--t-max-4", type=float, default=1000.0)
    ap.add_argument("--t-max-5", type=float, default=200.0)
    ap.add_argument("--knobs", default="", help="only these knobs (comma list of names)")
    ap.add_argument("--plot-only", action="store_true", help="re-plot OUT/speed_accuracy.csv")
    a = ap.parse_args()
    if a.replicates < 2:
        sys.exit(f"speed_accuracy: --replicates = {a.replicates}: must be >= 2 (a CI needs two pairs)")
    if a.jobs < 1:
        sys.exit(f"speed_accuracy: --jobs = {a.jobs}: must be >= 1")
    for name, v in [("--t-max-4", a.t_max_4), ("--t-max-5", a.t_max_5)]:
        if not (v > 0 and math.isfinite(v)):
            sys.exit(f"speed_accuracy: {name} = {v}: must be a finite number > 0")
    csv_path, png_path = a.out / "speed_accuracy.csv", a.out / "speed_accuracy.png"
    if a.plot_only:
        if not csv_path.is_file():
            sys.exit(f"speed_accuracy: --plot-only: no {csv_path} (run without --plot-only first)")
        with open(csv_path) as f:
            rows = [{k: (float(v) if k not in ("scenario", "knob", "value") else v) for k, v in r.items()}
                    for r in csv.DictReader(f)]
        plot(rows, png_path)
        return
    table = knob_table()
    scens = [s.strip() for s in a.scenarios.split(",") if s.strip()]
    for s in scens:
        if s not in table:
            sys.exit(f"speed_accuracy: --scenarios: unknown scenario '{s}' (valid: {', '.join(table)})")
    wanted = {k.strip() for k in a.knobs.split(",") if k.strip()}
    known = {k[0] for s in scens for k in table[s][1]["knobs"]}
    if wanted - known:
        sys.exit(f"speed_accuracy: --knobs: unknown {sorted(wanted - known)} (valid: {sorted(known)})")
    repo = pathlib.Path(__file__).resolve().parent.parent
    (a.out / "runs").mkdir(parents=True, exist_ok=True)
    rows = []
    with cf.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        for s in scens:
            name, spec = table[s]
            t_max = a.t_max_4 if s == "4" else a.t_max_5
            sfile = repo / "jobs" / "scenarios" / f"{name}.toml"
            base = {"run.t_max": t_max}
            ref_sets = {**base, **spec["reference"]}
            print(f"scenario {s}: reference {ref_sets}", file=sys.stderr, flush=True)
            ref = run_cached(pool, a.out / "runs" / f"{s}__t{t_max:g}__reference.jsonl", a.ringsim, sfile,
                             a.seed, a.replicates, ref_sets)
            default = run_cached(pool, a.out / "runs" / f"{s}__t{t_max:g}__default.jsonl", a.ringsim, sfile,
                                 a.seed, a.replicates, base)
            rows.append(summarize(s, "reference", "reference", False, ref, ref, default, t_max))
            for knob, values, default_label in spec["knobs"]:
                if wanted and knob not in wanted:
                    continue
                for label, sets in values:
                    if label == default_label:
                        sets = {}  # every knob at its default: one shared run
                    sets_all = {**base, **sets}
                    tag = f"{s}__t{t_max:g}__" + ("__".join(f"{k}={v}" for k, v in sorted(sets.items()))
                                                   if sets else "default")
                    print(f"scenario {s}: {knob} = {label}", file=sys.stderr, flush=True)
                    got = run_cached(pool, a.out / "runs" / f"{tag}.jsonl", a.ringsim, sfile, a.seed,
                                     a.replicates, sets_all)
                    rows.append(summarize(s, knob, label, label == default_label, got, ref, default, t_max))
                    r = rows[-1]
                    print(f"  median wall {r['median_wall_s']:.2f} s, N_t dev "
                          f"{r['N_t_dev']:+.1f} ± {r['N_t_dev_ci']:.1f}", file=sys.stderr, flush=True)
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    plot(rows, png_path)
    print(f"wrote {csv_path} and {png_path}", file=sys.stderr)


if __name__ == "__main__":
    main()
