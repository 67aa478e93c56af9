#!/usr/bin/python3
"""Ring-size histograms side by side: one panel per scenario, one bar series
per label (e.g. the articulated and welded readings of the same seeds),
rings per replicate by the number m of spheres in the ring.

A source is a bench/run_scenarios.sh output directory (the "rings" field of
`ringsim replicate --json` in DIR/<scenario>.jsonl) or an HDF5 result file
of `ringsim run` (its ring_2 ... ring_12 columns; rings of more than 12
spheres, ring_over, are one bar labelled ">12") or a CSV of
bench/summarize_scenarios.py (its R, failed and "rings" columns, for
ensembles whose replicate files are not kept). Only finished
replicates count (failed and pending ones are left out). Several sources may
share a label (LABEL=a.h5 LABEL=b.h5): their scenarios are merged.

Usage: /usr/bin/python3 bench/plot_rings.py OUT.png LABEL=SOURCE [LABEL=SOURCE...]
"""
import json
import pathlib
import sys

OVER = 10**9  # the key of ring_over (m > 12) in an HDF5 source: sorts last

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def load(directory):
    """{scenario: (replicates, {m: rings})} from DIR/<scenario>.jsonl."""
    out = {}
    for path in sorted(pathlib.Path(directory).glob("*.jsonl")):
        reps, rings = 0, {}
        for line in path.read_text().splitlines():
            if not line.strip():
                continue
            r = json.loads(line)
            reps += 1
            for m, c in (r.get("rings") or {}).items():
                rings[int(m)] = rings.get(int(m), 0) + c
        out[path.stem] = (reps, rings)
    return out


def load_h5(path):
    """{scenario: (replicates, {m: rings})} from a `ringsim run` result file."""
    import h5py  # only needed for HDF5 sources

    with h5py.File(path, "r") as f:
        name = f.attrs["scenario"]
        name = name.decode() if isinstance(name, bytes) else str(name)
        rows = f["replicates"][:]
    rows = rows[rows["status"] == 1]  # RecordStatus::Ok
    rings = {}
    for field in rows.dtype.names:
        if field.startswith("ring_"):
            m = OVER if field == "ring_over" else int(field[5:])
            count = int(rows[field].sum())
            if count:
                rings[m] = count
    return {name: (len(rows), rings)}


def load_csv(path):
    """{scenario: (replicates, {m: rings})} from summarize_scenarios.py --format csv."""
    import csv

    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            rings = {}
            for item in row["rings"].split():
                m, c = item.split(":")
                rings[int(m)] = int(c)
            out[row["scenario"]] = (int(row["R"]) - int(row["failed"]), rings)
    return out


def load_source(source):
    if source.endswith(".h5"):
        return load_h5(source)
    if source.endswith(".csv"):
        return load_csv(source)
    return load(source)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    target = sys.argv[1]
    series = []
    for arg in sys.argv[2:]:
        label, sep, source = arg.rpartition("=")  # the label may contain "=", the path not
        if not sep or not pathlib.Path(source).exists():
            sys.exit(f"plot_rings: {arg!r}: expected LABEL=SOURCE with SOURCE an existing run_scenarios.sh "
                     "directory, `ringsim run` .h5 file or summarize_scenarios.py .csv")
        data = load_source(source)
        for existing, d in series:
            if existing == label:
                d.update(data)
                break
        else:
            series.append((label, data))
    scenarios = sorted({s for _, d in series for s in d})
    fig, axes = plt.subplots(1, len(scenarios), figsize=(3.2 * len(scenarios), 3.0), squeeze=False)
    width = 0.8 / len(series)
    for ax, name in zip(axes[0], scenarios):
        sizes = sorted({m for _, d in series for m in d.get(name, (0, {}))[1]}) or [4]
        for k, (label, d) in enumerate(series):
            reps, rings = d.get(name, (0, {}))
            ys = [rings.get(m, 0) / reps if reps else 0.0 for m in sizes]
            xs = [i + (k - (len(series) - 1) / 2) * width for i in range(len(sizes))]
            ax.bar(xs, ys, width, label=f"{label} (R={reps})")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("spheres in ring m")
        ax.set_xticks(range(len(sizes)))
        ax.set_xticklabels([">12" if m == OVER else str(m) for m in sizes])
        ax.legend(fontsize=7)  # per panel: R differs between scenarios
    axes[0][0].set_ylabel("rings per replicate")
    fig.tight_layout()
    fig.savefig(target, dpi=110)
    print(target)


if __name__ == "__main__":
    main()
