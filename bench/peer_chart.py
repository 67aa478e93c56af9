#!/usr/bin/python3
"""Cost against error: ringsim's exact core against the time-stepped Bullet
peer (bench/peer, issue 35, docs/PEER.md).

Two studies, each one command:

  gas        the hard-body gas (the built-in scene with bonding off: 300
             spheres + 300 linkers, box 50, restitution 1) to t = T. Per
             method and setting, R replicates; replicate r of every setting
             starts from the same scene. Errors: |energy drift| (final
             kinetic energy / initial - 1), the collision count against
             ringsim's at its default tolerance on the same replicate
             (|ratio - 1|), and the largest penetration (ringsim's contacts
             fire at a gap in [delta/2, delta]: none). Cost: median wall
             seconds per replicate (set-up included).
  scenario   a scenario file with bonding, R replicates per setting: the
             observables N_t, Phi_viab, M_mono, S4, Phi_obj, the peer's
             paired difference from ringsim (same seeds) with a 95 % CI
             (Student t), and cost. Both methods run the bond reading of
             --joint (welded by default; passed to ringsim when it knows the
             key bonding.joint).

ringsim's settings are its accuracy knob run.contact_tolerance; the peer's
are dt, in single precision (ringsim_peer) and, when given, double
(ringsim_peer64). Output in OUT: runs/*.jsonl (one JSON line per replicate,
appended as each run ends; the same command after a stop runs only the
missing replicates), <study>.csv and <study>.png (or --chart BASE: BASE.csv
and BASE.png).

Usage:
  /usr/bin/python3 bench/peer_chart.py gas --ringsim build/ringsim \\
      --peer build/bench/peer/ringsim_peer [--peer64 build/bench/peer/ringsim_peer64] \\
      --out OUT [-R 2] [--t-max 500] [--dts 0.05,0.02,0.01,0.005,0.002] [--plot-only] [--chart BASE]
  /usr/bin/python3 bench/peer_chart.py scenario --scenario jobs/scenarios/4-passive-selection.toml \\
      --ringsim build/ringsim --peer build/bench/peer/ringsim_peer --out OUT [-R 8] [--t-max 5000] \\
      [--joint welded|articulated]

The runs go one at a time (--jobs 1) so that wall times are not shared; on
a cluster node of its own, --jobs N with N cores (docs/PEER.md, "The full
protocol on a cluster").
"""
import argparse
import collections
import concurrent.futures as cf
import csv
import json
import math
import pathlib
import statistics
import subprocess
import sys

TOLERANCES = ["1e-10", "1e-9", "1e-7", "1e-5"]
DTS = "0.05,0.02,0.01,0.005,0.002"
OBSERVABLES = ["N_t", "Phi_viab", "M_mono", "S4", "Phi_obj"]


def run_one(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode in (0, 3) and p.stdout.strip():
        return json.loads(p.stdout)
    raise RuntimeError(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()}")


def read_runs(path):
    """The replicates kept in path, by replicate index. A line cut short by a
    crash is dropped (its replicate runs again) and the file rewritten
    without it, so that appended lines start on a line of their own."""
    if not path.exists():
        return {}
    done, text = {}, path.read_text()
    lines = [line for line in text.splitlines() if line.strip()]
    good = []
    for line in lines:
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            continue
        if row.get("replicate") is None or int(row["replicate"]) in done:
            continue
        done[int(row["replicate"])] = row
        good.append(line)
    if len(good) != len(lines) or (text and not text.endswith("\n")):
        path.write_text("".join(line + "\n" for line in good))
    return done


# One setting's runs: its file, the rows kept by replicate, the runs under
# way (future -> replicate) and how many replicates it needs.
Job = collections.namedtuple("Job", "path done futures reps")


def start(pool, path, make_cmd, reps):
    """Submit the replicates among 0..reps-1 that path does not hold yet."""
    done = read_runs(path)
    return Job(path, done, {pool.submit(run_one, make_cmd(r)): r for r in range(reps) if r not in done}, reps)


def gather(jobs):
    """Wait for the runs of every job of start(), in the order they end,
    appending each replicate's JSON line to its setting's file the moment
    it ends: a stopped study (time limit, node failure, Ctrl-C) loses only
    the runs under way, and the same command runs just the replicates the
    files lack. A failed run does not discard the others: they are kept,
    then its error is raised. Returns each job's replicates 0..reps-1."""
    owner = {f: job for job in jobs for f in job.futures}
    total, error = len(owner), None
    for n, future in enumerate(cf.as_completed(owner), 1):
        path, done, r = owner[future].path, owner[future].done, owner[future].futures[future]
        try:
            row = future.result()
        except Exception as e:  # noqa: BLE001 (re-raised below)
            error = error or e
            print(f"[{n}/{total}] {path.stem} replicate {r}: FAILED ({e})", file=sys.stderr, flush=True)
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("a") as f:
            f.write(json.dumps(row) + "\n")
        done[r] = row
        wall = row.get("wall_seconds")
        wall = f"{wall:.1f} s" if isinstance(wall, (int, float)) else "done"
        print(f"[{n}/{total}] {path.stem} replicate {r}: {wall}", file=sys.stderr, flush=True)
    if error is not None:
        raise error
    return [[job.done[r] for r in range(job.reps)] for job in jobs]


def t_quantile(n):
    """Two-sided 95 % Student t quantile for n - 1 degrees of freedom."""
    try:
        from scipy import stats
        return float(stats.t.ppf(0.975, n - 1))
    except ImportError:  # pragma: no cover
        return 1.96


def mean_ci(values):
    vals = [v for v in values if v is not None and math.isfinite(v)]
    if not vals:
        return float("nan"), float("nan"), 0
    m = statistics.fmean(vals)
    if len(vals) < 2:
        return m, float("nan"), len(vals)
    return m, t_quantile(len(vals)) * statistics.stdev(vals) / math.sqrt(len(vals)), len(vals)


def energy_drift(row):
    e = row["energy"]["translational"] + row["energy"]["rotational"]
    return e / row["energy_budget"]["initial"] - 1.0


def knows_joint_key(ringsim):
    """Whether this ringsim has the key bonding.joint (older builds are
    welded only and refuse the key)."""
    p = subprocess.run([ringsim, "keys"], capture_output=True, text=True)
    return any(line.startswith("bonding.joint ") for line in p.stdout.splitlines())


def settings(a):
    """(method, label, command maker) for every setting of the study."""
    out = []
    base = [] if a.scenario is None else [a.scenario]
    sets = ["--set", f"run.t_max={a.t_max}"] + sum((["--set", s] for s in a.set), [])
    if a.study == "gas":
        sets += ["--set", "bonding.enabled=false"]
    # Both methods in the same bond reading (--joint; welded by default,
    # the reading the earlier charts used).
    joint = ["--set", f"bonding.joint={a.joint}"] if a.study == "scenario" else []
    ringsim_joint = joint if joint and knows_joint_key(a.ringsim) else []
    for tol in TOLERANCES:
        out.append(("ringsim", tol, lambda r, tol=tol: [a.ringsim, "replicate", *base, "--seed", str(a.seed),
                                                        "--replicate", str(r), "--json", *sets, *ringsim_joint,
                                                        "--set", f"run.contact_tolerance={tol}"]))
    peers = [("bullet-float", a.peer)] + ([("bullet-double", a.peer64)] if a.peer64 else [])
    for method, exe in peers:
        for dt in a.dts.split(","):
            extra = joint
            out.append((method, dt, lambda r, exe=exe, dt=dt, extra=extra: [
                exe, *base, "--seed", str(a.seed), "--replicate", str(r), "--dt", dt, *sets, *extra]))
    return out


def tag(a):
    name = "gas" if a.scenario is None else pathlib.Path(a.scenario).stem
    joint = "__articulated" if a.study == "scenario" and a.joint == "articulated" else ""
    return f"{name}__t{a.t_max}" + joint + "".join("__" + s.replace("=", "-") for s in a.set)


def collect(a):
    """Every setting's replicates. All settings' missing runs are submitted
    at once, so that --jobs N keeps N cores busy across settings."""
    out = pathlib.Path(a.out)
    rows, pending = {}, []
    pool = cf.ThreadPoolExecutor(max_workers=a.jobs)
    try:
        for method, label, make in settings(a):
            path = out / "runs" / f"{tag(a)}__{method}__{label}.jsonl"
            if a.plot_only:
                if path.exists():
                    rows[(method, label)] = [row for r, row in sorted(read_runs(path).items()) if r < a.R]
                continue
            job = start(pool, path, make, a.R)
            print(f"{method} {label}: {a.R} replicates, {len(job.futures)} to run", file=sys.stderr, flush=True)
            pending.append(((method, label), job))
        rows.update(zip([key for key, _ in pending], gather([job for _, job in pending])))
    except KeyboardInterrupt:
        # Ctrl-C: the runs under way got it too; start no queued one.
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    return rows


def failure_text(runs):
    """Failure modes the peer recorded, summed over replicates (docs/PEER.md)."""
    total = {}
    for r in runs:
        for k, v in r.get("peer", {}).get("failures", {}).items():
            total[k] = total.get(k, 0) + v["count"]
    errors = sum(r["termination"] == "error" for r in runs)
    parts = [f"{k}:{v}" for k, v in sorted(total.items()) if v]
    if errors:
        parts.append(f"error_runs:{errors}")
    return " ".join(parts)


def gas_table(a, rows):
    ref = rows.get(("ringsim", "1e-9"))
    table = []
    for (method, label), runs in rows.items():
        if not runs:
            continue
        cost = statistics.median(r["wall_seconds"] for r in runs)
        drift = statistics.median(abs(energy_drift(r)) for r in runs)
        coll = [r["collisions"] for r in runs]
        ratio = [r["collisions"] / q["collisions"] - 1.0 for r, q in zip(runs, ref or []) if q["collisions"]]
        pen = statistics.median(r.get("peer", {}).get("max_penetration", 0.0) for r in runs)
        table.append({"method": method, "setting": label, "R": len(runs), "median_wall_s": cost,
                      "median_abs_energy_drift": drift, "mean_collisions": statistics.fmean(coll),
                      "collision_ratio_minus_1": statistics.fmean(ratio) if ratio else float("nan"),
                      "median_max_penetration": pen, "failures": failure_text(runs)})
    return table


def scenario_table(a, rows):
    ref = rows.get(("ringsim", "1e-9"))
    table = []
    for (method, label), runs in rows.items():
        if not runs:
            continue
        row = {"method": method, "setting": label, "R": len(runs),
               "median_wall_s": statistics.median(r["wall_seconds"] for r in runs),
               "failures": failure_text(runs)}
        for ob in OBSERVABLES:
            m, h, n = mean_ci([r[ob] for r in runs])
            row[ob] = m
            row[ob + "_ci"] = h
            diffs = [r[ob] - q[ob] for r, q in zip(runs, ref or [])
                     if r[ob] is not None and q[ob] is not None]
            dm, dh, dn = mean_ci(diffs)
            row[ob + "_diff"] = dm
            row[ob + "_diff_ci"] = dh
        table.append(row)
    return table


def write_csv(path, table):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0].keys()))
        w.writeheader()
        for row in table:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})


STYLE = {"ringsim": ("C0", "o"), "bullet-float": ("C3", "s"), "bullet-double": ("C2", "^")}


def plot_paired(path, table, keys, title):
    """Scenario study: each observable's paired difference from ringsim at
    its default (signed, with its 95 % CI) against cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(keys), figsize=(4.6 * len(keys), 4.0))
    for ax, ob in zip(axes, keys):
        for method in STYLE:
            pts = sorted((r["median_wall_s"], r[ob + "_diff"], r[ob + "_diff_ci"], r["setting"])
                         for r in table if r["method"] == method and math.isfinite(r[ob + "_diff"]))
            if not pts:
                continue
            colour, marker = STYLE[method]
            ax.errorbar([p[0] for p in pts], [p[1] for p in pts],
                        yerr=[p[2] if math.isfinite(p[2]) else 0.0 for p in pts],
                        marker=marker, color=colour, label=method, capsize=3)
            for x, y, _, lab in pts:
                if method == "ringsim" and lab == "1e-9":
                    lab += " (reference)"
                ax.annotate(lab, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.axhline(0.0, color="grey", lw=0.6)
        ax.set_xscale("log")
        ax.set_xlabel("median wall s per replicate")
        ax.set_ylabel(f"{ob}: paired difference from ringsim (95 % CI)")
        ax.grid(True, which="both", lw=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot(path, table, panels, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 4.0))
    for ax, (key, ylabel, floor) in zip(axes, panels):
        for method in STYLE:
            pts = [(r["median_wall_s"], abs(r[key]), r["setting"]) for r in table if r["method"] == method]
            pts = [p for p in pts if math.isfinite(p[1])]
            if not pts:
                continue
            pts.sort()
            colour, marker = STYLE[method]
            ys = [max(y, floor) for _, y, _ in pts]
            ax.plot([x for x, _, _ in pts], ys, marker=marker, color=colour, label=method)
            for (x, y, lab), yy in zip(pts, ys):
                if method == "ringsim" and lab == "1e-9" and ("diff" in key or "collision" in key):
                    lab += " (reference)"
                ax.annotate(lab, (x, yy), fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("median wall s per replicate")
        ax.set_ylabel(ylabel)
        ax.axhline(floor, color="grey", lw=0.5, ls=":")
        ax.grid(True, which="both", lw=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("study", choices=["gas", "scenario"])
    ap.add_argument("--scenario", default=None, help="scenario file (study 'scenario')")
    ap.add_argument("--ringsim", required=True)
    ap.add_argument("--peer", required=True)
    ap.add_argument("--peer64", default=None)
    ap.add_argument("--out", required=True)
    ap.add_argument("-R", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--t-max", type=float, default=None)
    ap.add_argument("--dts", default=DTS)
    ap.add_argument("--joint", choices=["welded", "articulated"], default="welded",
                    help="bond reading of both methods (study 'scenario')")
    ap.add_argument("--set", action="append", default=[], help="extra SECTION.KEY=VALUE for both methods")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--plot-only", action="store_true")
    ap.add_argument("--chart", default=None,
                    help="write the chart to CHART.csv and CHART.png (default OUT/<study tag>)")
    a = ap.parse_args()
    if a.jobs < 1:
        sys.exit(f"peer_chart: --jobs {a.jobs}: runs at a time must be at least 1")
    if a.R < 1:
        sys.exit(f"peer_chart: -R {a.R}: replicates per setting must be at least 1")
    if a.study == "scenario" and a.scenario is None:
        sys.exit("peer_chart: the scenario study needs --scenario FILE")
    if a.study == "gas" and a.scenario is not None:
        sys.exit("peer_chart: the gas study uses the built-in scene (no --scenario)")
    if a.t_max is None:
        a.t_max = 500 if a.study == "gas" else 5000
    a.t_max = f"{a.t_max:g}"
    rows = collect(a)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    name = tag(a)
    if a.study == "gas":
        table = gas_table(a, rows)
        panels = [("median_abs_energy_drift", "|energy drift| (floor 1e-16)", 1e-16),
                  ("collision_ratio_minus_1", "|collisions / ringsim's - 1| (floor 1e-4)", 1e-4),
                  ("median_max_penetration", "largest penetration (ringsim: none; floor 1e-6)", 1e-6)]
        title = f"Hard-body gas, 300 S + 300 L, T = {a.t_max}, R = {a.R} (median)"
    else:
        table = scenario_table(a, rows)
        title = f"{name}, R = {a.R}: the peer ({a.joint} bonds) against ringsim, same seeds"
    base = pathlib.Path(a.chart) if a.chart else out / name
    write_csv(base.with_suffix(".csv"), table)
    if a.study == "gas":
        plot(base.with_suffix(".png"), table, panels, title)
    else:
        plot_paired(base.with_suffix(".png"), table, ["N_t", "M_mono", "Phi_viab"], title)
    print(f"wrote {base.with_suffix('.csv')} and {base.with_suffix('.png')}")


if __name__ == "__main__":
    main()
