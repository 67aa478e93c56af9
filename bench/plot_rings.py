#!/usr/bin/python3
"""Ring-size histograms of bench/run_scenarios.sh outputs, side by side: one
panel per scenario, one bar series per output directory (e.g. the
articulated and welded readings of the same seeds), rings per replicate by
the number m of spheres in the ring (the "rings" field of
`ringsim replicate --json`).

Usage: /usr/bin/python3 bench/plot_rings.py OUT.png LABEL=DIR [LABEL=DIR...]
"""
import json
import pathlib
import sys

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


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    target = sys.argv[1]
    series = [(a.split("=", 1)[0], load(a.split("=", 1)[1])) for a in sys.argv[2:]]
    scenarios = sorted({s for _, d in series for s in d})
    fig, axes = plt.subplots(1, len(scenarios), figsize=(3.2 * len(scenarios), 3.0), squeeze=False)
    width = 0.8 / len(series)
    for ax, name in zip(axes[0], scenarios):
        sizes = sorted({m for _, d in series for m in d.get(name, (0, {}))[1]}) or [4]
        for k, (label, d) in enumerate(series):
            reps, rings = d.get(name, (0, {}))
            ys = [rings.get(m, 0) / reps if reps else 0.0 for m in sizes]
            ax.bar([m + (k - (len(series) - 1) / 2) * width for m in sizes], ys, width, label=f"{label} (R={reps})")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("spheres in ring m")
        ax.set_xticks(sizes)
    axes[0][0].set_ylabel("rings per replicate")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(target, dpi=110)
    print(target)


if __name__ == "__main__":
    main()
