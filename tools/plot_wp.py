#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Work-precision plot from the CSV of `defsim bench`.

Left: RMS position error at the end time (relative to the body size) against the median wall
time of the stepping loop, log-log, one line per backend; every point is labelled with its step
size h (fixed-step backends) or tolerance (sundials_ida); the dashed grey staircase is the Pareto
front. Right: the energy error against the same times. Runs that failed or diverged are left out
(they are listed under the plot).

    python3 tools/plot_wp.py bench_cantilever/cantilever.csv [--out PNG] [--title TEXT]

A CSV of `defsim bench --spatial` (it has the columns order and cells) gives the plot against
the continuum instead: left, the total error (RMS over frames and sample points) against the CPU
time of the stepping loop, one colour per element order and mesh, one marker per backend, the
front dashed; right, the smallest error reached on each mesh against its vertex count (the
spatial convergence), one line per element order.

Exit status: 0 written, 2 bad input, 3 matplotlib is not installed.
"""
import argparse
import csv
import sys

COLORS = {"explicit_euler": "#c62828", "symplectic_euler": "#2e7d32",
          "velocity_verlet": "#00897b", "newton_cholmod": "#1565c0", "newmark": "#5e35b1",
          "bdf2": "#3949ab", "sundials_kinsol": "#6a1b9a", "sundials_ida": "#ef6c00",
          "sundials_erk": "#c62828"}
MARKERS = {"explicit_euler": "x", "symplectic_euler": "o", "velocity_verlet": "P",
           "newton_cholmod": "s", "newmark": "v", "bdf2": "<", "sundials_kinsol": "D",
           "sundials_ida": "^", "sundials_erk": "X"}


def label(r):
    v = float(r["value"])
    return f"{v:.0e}" if r["kind"] == "tol" else f"h={v:.2g}"


def front(points):
    """The staircase of the fastest way to each error level among (time, error) points."""
    fx, fy, best = [], [], float("inf")
    for x, y in sorted(points):
        if y < best:
            if fx:
                fx.append(x)
                fy.append(best)
            fx.append(x)
            fy.append(y)
            best = y
    return fx, fy


def plot_spatial(plt, rows, out, title):
    ok = [r for r in rows if r["status"] == "ok" and float(r["rms_err"]) > 0]
    bad = [r for r in rows if r["status"] != "ok"]
    meshes = list(dict.fromkeys((r["order"], r["cells"]) for r in rows))
    cmaps = {"linear": plt.get_cmap("Blues"), "quadratic": plt.get_cmap("Oranges")}
    colour = {}
    for order in ("linear", "quadratic"):
        ms = [m for m in meshes if m[0] == order]
        for k, m in enumerate(ms):
            colour[m] = cmaps[order](0.45 + 0.55 * k / max(1, len(ms) - 1))
    fig, axes = plt.subplots(1, 2, figsize=(14, 6))
    ax = axes[0]
    for m in meshes:
        for b in dict.fromkeys(r["backend"] for r in ok):
            rs = sorted((r for r in ok if (r["order"], r["cells"]) == m and r["backend"] == b),
                        key=lambda r: float(r["cpu_s"]))
            if not rs:
                continue
            xs = [float(r["cpu_s"]) for r in rs]
            ys = [float(r["rms_err"]) for r in rs]
            ax.plot(xs, ys, marker=MARKERS.get(b, "o"), color=colour[m], lw=1.2, ms=7,
                    label=f"{m[0]} {m[1]}, {b}", mec="k", mew=0.4)
            for r, x, y in zip(rs, xs, ys):
                ax.annotate(f"h={float(r['value']):.2g}", (x, y), textcoords="offset points",
                            xytext=(4, 3), fontsize=6, color="0.3")
    fx, fy = front((float(r["cpu_s"]), float(r["rms_err"])) for r in ok)
    if fx:
        ax.plot(fx, fy, ls="--", color="0.4", lw=1, zorder=0, label="front")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("CPU time of the stepping loop (s, median, one thread)")
    ax.set_ylabel("RMS position error over frames and points / body size")
    ax.set_title("total error against cost")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6.5, loc="best", ncol=2)
    ax = axes[1]
    for order, mk in (("linear", "s"), ("quadratic", "o")):
        pts = []
        for m in meshes:
            if m[0] != order:
                continue
            es = [float(r["rms_err"]) for r in ok if (r["order"], r["cells"]) == m]
            vs = [int(r["vertices"]) for r in rows if (r["order"], r["cells"]) == m]
            if es:
                pts.append((vs[0], min(es), m[1]))
        pts.sort()
        if not pts:
            continue
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=mk, lw=1.5,
                color=cmaps[order](0.8), label=f"{order} tets")
        for v, e, c in pts:
            ax.annotate(c, (v, e), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("vertices")
    ax.set_ylabel("smallest error on the mesh (any backend, step)")
    ax.set_title("spatial convergence")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    text = "; ".join(f"{r['order']} {r['cells']} {r['backend']} h={float(r['value']):.2g} "
                     f"{r['status']}" for r in bad)
    return finish(fig, out, text, 0.95)


def finish(fig, out, left_out, top):
    """Lists the runs left out under the plot (if any), lays it out and saves it."""
    if left_out:
        fig.text(0.01, 0.01, "left out: " + left_out, fontsize=7, wrap=True)
    fig.tight_layout(rect=(0, 0.05 if left_out else 0, 1, top))
    fig.savefig(out, dpi=110)
    print(out)
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("--out", default=None, help="PNG path (default: the CSV's with .png)")
    ap.add_argument("--title", default=None)
    a = ap.parse_args()
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_wp.py: matplotlib is not installed (pip install matplotlib)", file=sys.stderr)
        return 3
    try:
        rows = list(csv.DictReader(open(a.csv)))
    except OSError as e:
        print(f"plot_wp.py: {e}", file=sys.stderr)
        return 2
    out = a.out or (a.csv[:-4] if a.csv.endswith(".csv") else a.csv) + ".png"
    spatial = {"order", "cells", "vertices", "backend", "value", "cpu_s", "rms_err", "status"}
    if rows and spatial <= set(rows[0]):
        return plot_spatial(plt, rows, out, a.title)
    need = {"backend", "kind", "value", "wall_s", "rms_err", "energy_err", "status"}
    if not rows or not need <= set(rows[0]):
        print(f"plot_wp.py: {a.csv}: not a defsim bench CSV", file=sys.stderr)
        return 2
    ok = [r for r in rows if r["status"] == "ok"]
    bad = [r for r in rows if r["status"] != "ok"]
    backends = list(dict.fromkeys(r["backend"] for r in rows))

    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6))
    for ax, col, ylab in ((axes[0], "rms_err", "RMS position error at T / body size"),
                          (axes[1], "energy_err", "|E(T) - E_ref(T)| / energy scale")):
        for b in backends:
            rs = sorted((r for r in ok if r["backend"] == b), key=lambda r: float(r["wall_s"]))
            rs = [r for r in rs if float(r[col]) > 0]
            if not rs:
                continue
            xs = [float(r["wall_s"]) for r in rs]
            ys = [float(r[col]) for r in rs]
            ax.plot(xs, ys, marker=MARKERS.get(b, "o"), color=COLORS.get(b), label=b, lw=1.5,
                    ms=6)
            for r, x, y in zip(rs, xs, ys):
                ax.annotate(label(r), (x, y), textcoords="offset points", xytext=(4, 4),
                            fontsize=7, color=COLORS.get(b, "k"))
        if col == "rms_err":
            # Pareto front: the fastest way to each error level reached.
            fx, fy = front((float(r["wall_s"]), float(r["rms_err"])) for r in ok
                           if float(r["rms_err"]) > 0)
            if fx:
                ax.plot(fx, fy, ls="--", color="0.5", lw=1, zorder=0, label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time of the stepping loop (s, median)")
        ax.set_ylabel(ylab)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    axes[0].set_title("position error")
    axes[1].set_title("energy error")
    if a.title:
        fig.suptitle(a.title)
    groups = {}
    for r in bad:
        groups.setdefault((r["backend"], r["status"]), []).append(label(r))
    return finish(fig, out, "; ".join(f"{b} {s} at {', '.join(v)}"
                                      for (b, s), v in groups.items()), 0.96)


if __name__ == "__main__":
    sys.exit(main())
