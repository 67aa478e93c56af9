#!/usr/bin/python3
"""Tile PNG images into one figure, in rows of COLS, each under its title.

Usage: /usr/bin/python3 bench/montage.py OUT.png COLS TITLE=IMAGE.png [TITLE=IMAGE.png...]
(e.g. the rendered final configurations of several scenarios,
scripts/render_snapshot.py, side by side for docs/RESULTS.md).
"""
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) < 4 or "=" not in sys.argv[3]:
        sys.exit(__doc__)
    out, cols = sys.argv[1], int(sys.argv[2])
    items = [a.split("=", 1) for a in sys.argv[3:]]
    rows = math.ceil(len(items) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.4 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, (title, path) in zip(axes.flat, items):
        ax.imshow(mpimg.imread(path))
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=80)


if __name__ == "__main__":
    main()
