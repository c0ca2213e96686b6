#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Total-energy error against time from the energy.csv files of `defsim run`, one line per run.

The error is E(t) - E(0) divided by the largest kinetic energy of the first run (the energy in
motion), so that a line at 0 conserves energy and a line at -1 has lost as much as ever moved.

    python3 tools/plot_energy.py LABEL=RUN_DIR/energy.csv [...] --out PNG [--title TEXT]

Exit status: 0 written, 2 bad input, 3 matplotlib is not installed.
"""
import argparse
import csv
import importlib.util
import sys


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    return ([float(r["time"]) for r in rows], [float(r["total"]) for r in rows],
            [float(r["kinetic"]) for r in rows])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="LABEL=path/to/energy.csv")
    parser.add_argument("--out", required=True, help="PNG path")
    parser.add_argument("--title", default="total energy error")
    a = parser.parse_args()
    if importlib.util.find_spec("matplotlib") is None:
        print("plot_energy.py: matplotlib is not installed", file=sys.stderr)
        return 3
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    runs = []
    try:
        for spec in a.runs:
            lab, sep, path = spec.partition("=")
            if not sep:
                raise ValueError(f"{spec}: want LABEL=PATH")
            runs.append((lab, *read(path)))
    except (OSError, ValueError, KeyError) as e:
        print(f"plot_energy.py: {e}", file=sys.stderr)
        return 2
    scale = max(runs[0][3])
    if not scale > 0.0:
        print("plot_energy.py: the first run never moves (zero kinetic energy)", file=sys.stderr)
        return 2
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for k, ax in enumerate(axes):
        for lab, t, e, _ in runs:
            err = [(x - e[0]) / scale for x in e]
            worst = max(abs(x) for x in err)
            ax.plot(t, err, label=f"{lab} (largest |error| {worst:.2g}, end {err[-1]:+.2g})")
        ax.axhspan(-0.01, 0.01, color="0.88", label="1 % band")
        ax.axhline(0.0, color="0.4", linewidth=0.8)
        ax.set_xlabel("time (s)")
        ax.grid(True, alpha=0.3)
        if k == 1:
            ax.set_ylim(-0.015, 0.015)
            ax.set_title("the same, zoomed to the 1 % band")
    axes[0].set_ylabel("(E(t) - E(0)) / largest kinetic energy")
    axes[0].set_title(a.title)
    axes[0].legend(loc="lower left", fontsize=9)
    fig.tight_layout()
    fig.savefig(a.out, dpi=110)
    print(f"plot_energy.py: wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
