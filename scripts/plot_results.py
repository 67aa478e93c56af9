#!/usr/bin/python3
"""Plots from ringsim result files (HDF5 written by `ringsim run`).

  plot_results.py rings  FILES... -o rings.png    ring-size distribution per configuration
  plot_results.py series FILES... -o nt.png       N_t(t) of one replicate per file, with its MSER cut
  plot_results.py sweep  FILES... -o sweep.png    each Table 5 observable against the swept --set key(s)
  plot_results.py runs   FILES... [-o runs.md]    how the replicates ran, per configuration (Markdown):
                                                  how each ended, median wall time, bonds, rings

Files of the same configuration (the config_hash attribute) are merged, as
`ringsim aggregate` does: rows count once per (seed, id), only status 1
(ok) rows enter. Error bars are Student-t 95 % confidence half-widths.
Uses Debian's /usr/bin/python3 with python3-h5py, python3-numpy,
python3-scipy and python3-matplotlib. Layout of the files: docs/OUTPUT.md.
"""
import argparse
import sys
import tomllib
from collections import OrderedDict

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

TABLE5 = [("N_t", 1.0, "N_t"), ("tau_tar", 1.0, "tau_tar"), ("Phi_obj", 100.0, "Phi_obj (%)"),
          ("S4", 100.0, "S4 (%)"), ("Phi_viab", 100.0, "Phi_viab (%)"), ("M_mono", 100.0, "M_mono (%)")]
RING_COLUMNS = ["ring_2"] + [f"ring_{m}" for m in range(3, 13)] + ["ring_over"]
RING_LABELS = ["<3"] + [str(m) for m in range(3, 13)] + [">12"]


def text(value):
    return value.decode() if isinstance(value, bytes) else str(value)


def load(files):
    """Configurations in first-seen order: hash -> dict(label, overrides, config, rows, series)."""
    groups = OrderedDict()
    for path in files:
        with h5py.File(path, "r") as f:
            if text(f.attrs.get("program", b"")) != "ringsim":
                sys.exit(f"{path}: not a ringsim result file")
            key = text(f.attrs["config_hash"])
            g = groups.setdefault(key, {"label": text(f.attrs["scenario"]),
                                        "overrides": [o for o in text(f.attrs["overrides"]).split("\n") if o],
                                        "config": tomllib.loads(text(f.attrs["config_toml"])),
                                        "rows": {}, "series": {}})
            rows = f["replicates"][()]
            series = f["series/N_t"][()] if "series" in f else None
            for i, row in enumerate(rows):
                if row["status"] != 1:
                    continue
                ident = (int(row["seed"]), int(row["id"]))
                if ident not in g["rows"]:
                    g["rows"][ident] = row
                    if series is not None:
                        g["series"][ident] = series[i]
    return groups


def mean_ci(values):
    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    if v.size == 0:
        return np.nan, np.nan
    if v.size == 1:
        return v[0], np.nan
    return v.mean(), stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size)


def name(g):
    return g["label"] + (" [" + ", ".join(g["overrides"]) + "]" if g["overrides"] else "")


def plot_rings(groups, out):
    fig, ax = plt.subplots(figsize=(9, 4.5))
    width = 0.8 / max(1, len(groups))
    x = np.arange(len(RING_COLUMNS))
    for k, g in enumerate(groups.values()):
        rows = list(g["rows"].values())
        means, cis = zip(*(mean_ci([r[c] for r in rows]) for c in RING_COLUMNS))
        ax.bar(x + (k - (len(groups) - 1) / 2) * width, means, width, yerr=np.nan_to_num(cis),
               capsize=2, label=f"{name(g)} (n = {len(rows)})")
    ax.set_xticks(x, RING_LABELS)
    ax.set_xlabel("ring size m (spheres per ring)")
    ax.set_ylabel("rings per replicate, mean ± 95 % CI")
    ax.set_title("Ring-size distribution at the end of each replicate")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def plot_series(groups, out):
    fig, ax = plt.subplots(figsize=(9, 4.5))
    shown = 0
    for g in groups.values():
        if not g["series"]:
            continue
        ident = min(g["series"])
        nt = g["series"][ident]
        nt = nt[np.isfinite(nt)]
        dt = float(g["config"]["run"]["sample_interval"])
        t = np.arange(nt.size) * dt
        line, = ax.plot(t, nt, lw=1, label=f"{name(g)}, replicate {ident[1]}")
        cut = int(g["rows"][ident]["mser_truncation"])
        if cut >= 0:
            ax.axvline(cut * dt, color=line.get_color(), ls="--", lw=1)
        shown += 1
    if shown == 0:
        sys.exit("no N_t series in these files (run with --series)")
    ax.set_xlabel("t (reduced units)")
    ax.set_ylabel("N_t (objects)")
    ax.set_title("N_t(t); dashed: MSER truncation point (steady state from there on)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def write_runs(groups, out):
    """One Markdown row per configuration: how its replicates ended (counts
    of each termination), the median and total wall time of one replicate,
    mean t_end, bonds, captures and collisions, and the rings formed in all."""
    lines = ["| configuration | n | ended by | wall s, median (total) | t_end, mean | bonds | captures | "
             "collisions | rings (all replicates) |",
             "|:---|---:|:---|---:|---:|---:|---:|---:|---:|"]
    for g in groups.values():
        rows = list(g["rows"].values())
        ends = OrderedDict()
        for r in rows:
            ends[text(r["termination"])] = ends.get(text(r["termination"]), 0) + 1
        wall = np.array([r["wall_seconds"] for r in rows])
        rings = sum(int(r[c]) for r in rows for c in RING_COLUMNS)
        mean = lambda f: np.mean([float(r[f]) for r in rows])  # noqa: E731
        lines.append(f"| {name(g)} | {len(rows)} | " + ", ".join(f"{k} ({v})" for k, v in ends.items()) +
                     f" | {np.median(wall):.1f} ({wall.sum():.0f}) | {mean('t_end'):.0f} | {mean('bonds'):.0f} | "
                     f"{mean('captures'):.0f} | {mean('collisions'):.3g} | {rings} |")
    body = "\n".join(lines) + "\n"
    if out:
        with open(out, "w") as f:
            f.write(body)
    else:
        sys.stdout.write(body)


def swept_keys(groups):
    """Swept --set keys, those whose values differ between configurations.
    Keys that always change together (e.g. dtheta_deg and dphi_deg swept as
    one) form one axis, named "key1+key2" and valued by the first key."""
    per_group = [dict(o.partition("=")[::2] for o in g["overrides"]) for g in groups.values()]
    keys = list(OrderedDict.fromkeys(k for d in per_group for k in d))
    axes = OrderedDict()
    for k in keys:
        signature = tuple(d.get(k) for d in per_group)
        if len(set(signature)) > 1:
            axes.setdefault(signature, []).append(k)
    return ["+".join(ks) for ks in axes.values()]


def setting(g, key):
    section, _, field = key.split("+")[0].partition(".")
    return g["config"][section][field]


def plot_sweep(groups, out):
    keys = swept_keys(groups)
    if not keys or len(keys) > 2:
        sys.exit(f"sweep: need configurations differing in one or two --set keys, found {keys or 'none'}")
    x_key, curve_key = keys[0], (keys[1] if len(keys) == 2 else None)
    curves = OrderedDict()
    for g in groups.values():
        curves.setdefault(setting(g, curve_key) if curve_key else None, []).append(g)
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5))
    for ax, (field, scale, label) in zip(axes.flat, TABLE5):
        for cval, gs in curves.items():
            gs = sorted(gs, key=lambda g: setting(g, x_key))
            xs = [setting(g, x_key) for g in gs]
            m, c = zip(*(mean_ci([r[field] for r in g["rows"].values()]) for g in gs))
            ax.errorbar(xs, np.array(m) * scale, yerr=np.nan_to_num(np.array(c) * scale), marker="o", capsize=3,
                        label=f"{curve_key} = {cval}" if curve_key else None)
        if not any(np.isfinite(mean_ci([r[field] for r in g["rows"].values()])[0])
                   for gs in curves.values() for g in gs):
            ax.text(0.5, 0.5, "undefined in every replicate\n(S4: no rings)", transform=ax.transAxes,
                    ha="center", va="center", color="gray")
        ax.set_xlabel(x_key)
        ax.set_ylabel(label)
        if len(xs) > 2 and min(xs) > 0 and max(xs) / min(xs) >= 10:
            ax.set_xscale("log")
    if curve_key:
        axes.flat[0].legend(fontsize=8)
    fig.suptitle(f"Sweep of {x_key}" + (f" and {curve_key}" if curve_key else "") + " (mean ± 95 % CI)")
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("kind", choices=["rings", "series", "sweep", "runs"])
    p.add_argument("files", nargs="+")
    p.add_argument("-o", "--output", help="PNG file to write (runs: Markdown file, default standard output)")
    a = p.parse_args()
    if a.kind != "runs" and not a.output:
        p.error(f"{a.kind}: -o/--output PNG is required")
    groups = load(a.files)
    {"rings": plot_rings, "series": plot_series, "sweep": plot_sweep, "runs": write_runs}[a.kind](groups, a.output)
    if a.output:
        print(f"wrote {a.output}", file=sys.stderr if a.kind == "runs" else sys.stdout)


if __name__ == "__main__":
    main()
