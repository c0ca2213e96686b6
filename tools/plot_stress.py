#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Stability maps from the CSV of `defsim stress`: one PNG per backend.

Each panel is one scene and Poisson ratio; x is the step size h, y the stiffness E (log-log).
Every (h, E) cell holds one marker per start (rest, stretched, inverted, random velocity),
coloured by the run's class. The line is the library's predicted explicit limit for the rest
start (defsim_world_stable_step), the theoretical h = 2 / omega_max for symplectic Euler.

    python3 tools/plot_stress.py stress.csv [--out DIR]
"""
import argparse
import csv
import collections
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = {"stable": "#2e7d32", "energy_blowup": "#ef6c00", "non_finite": "#c62828",
          "clean_error": "#6a1b9a"}
STARTS = ["rest", "stretched", "inverted", "random_velocity"]
OFFSETS = {"rest": (-1, 1), "stretched": (1, 1), "inverted": (-1, -1), "random_velocity": (1, -1)}
MARKERS = {"rest": "o", "stretched": ">", "inverted": "v", "random_velocity": "*"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--out", default=".")
    a = ap.parse_args()
    rows = list(csv.DictReader(open(a.csv)))
    by_backend = collections.defaultdict(list)
    for r in rows:
        by_backend[r["backend"]].append(r)
    os.makedirs(a.out, exist_ok=True)
    for backend, rs in by_backend.items():
        panels = sorted({(r["scene"], float(r["nu"])) for r in rs})
        ncol = min(3, len(panels))
        nrow = (len(panels) + ncol - 1) // ncol
        fig, axes = plt.subplots(nrow, ncol, figsize=(4.4 * ncol, 3.9 * nrow + 0.6), squeeze=False)
        for ax in axes.flat[len(panels):]:
            ax.set_visible(False)
        for ax, (scene, nu) in zip(axes.flat, panels):
            sel = [r for r in rs if r["scene"] == scene and float(r["nu"]) == nu]
            for r in sel:
                h, E = float(r["h"]), float(r["E"])
                dx, dy = OFFSETS[r["start"]]
                ax.scatter(h * 10 ** (0.08 * dx), E * 10 ** (0.12 * dy), s=30,
                           marker=MARKERS[r["start"]], color=COLORS[r["class"]],
                           edgecolors="black", linewidths=0.3)
            pred = sorted({(float(r["E"]), float(r["h_predicted"])) for r in sel
                           if r["start"] == "rest" and math.isfinite(float(r["h_predicted"]))
                           and float(r["h_predicted"]) > 0})
            if pred:
                ax.plot([p[1] for p in pred], [p[0] for p in pred], "k--", lw=1,
                        label="predicted limit")
                ax.legend(loc="lower right", fontsize=7)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("step size h [s]")
            ax.set_ylabel("E [Pa]" if scene == "beam" else "E [Pa] (k = E * 1e-4 m)")
            ax.set_title(f"{scene}" + (f", nu = {nu:g}" if scene == "beam" else ""), fontsize=9)
            ax.grid(True, which="major", alpha=0.3)
        handles = [plt.Line2D([], [], marker="s", ls="", color=c, label=k) for k, c in COLORS.items()]
        handles += [plt.Line2D([], [], marker=MARKERS[s], ls="", color="gray", label=s) for s in STARTS]
        fig.legend(handles=handles, loc="upper center", ncol=4, fontsize=8, frameon=False)
        fig.suptitle(f"stability map: {backend}", y=0.01, fontsize=11)
        fig.tight_layout(rect=(0, 0.03, 1, 1 - 0.5 / (3.9 * nrow + 0.6)))
        path = os.path.join(a.out, f"stress_{backend}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        print(path)


if __name__ == "__main__":
    main()
