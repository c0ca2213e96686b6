# SPDX-License-Identifier: MIT
"""The --plot heat map: a sweep's status or a metric over two swept keys."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence, Union

import numpy as np

#: Colours of the statuses (others are grey).
STATUS_COLORS = {"ok": "#4c9a2a", "unstable": "#d1495b", "not_converged": "#edae49",
                 "timeout": "#8d6a9f", "crashed": "#222222", "error": "#7f7f7f",
                 "metric_error": "#a0a0a0", "interrupted": "#c0c0c0"}


def _label(v) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def _stable_step_marks(ax, df, kx, ky, xs, ys) -> list:
    """With the step size on the y axis, a dash in each column at the stable step that
    `defsim run` estimated at the start (the median over the column's variants), placed between
    the rows on a log scale: where explicit runs are expected to start failing."""
    if ky != "world.h" or "stable_step" not in df.columns or len(ys) < 2:
        return []
    import matplotlib.lines as mlines
    logs = np.log([float(y) for y in ys])
    drawn = False
    for j, x in enumerate(xs):
        hp = df.loc[df[kx] == x, "stable_step"].median()
        if not (isinstance(hp, float) and math.isfinite(hp) and hp > 0):
            continue
        if not logs[0] <= math.log(hp) <= logs[-1]:
            continue   # beyond the swept steps
        y = float(np.interp(math.log(hp), logs, np.arange(len(ys))))
        ax.plot([j - 0.5, j + 0.5], [y, y], color="black", lw=1.5, ls="--")
        drawn = True
    return [mlines.Line2D([], [], color="black", ls="--", label="estimated\nstable step")] \
        if drawn else []


def _text_width(texts, fontsize: float) -> float:
    """A generous estimate of the widest of `texts` in inches (DejaVu Sans: under 0.62 em per
    character)."""
    return max((len(t) for t in texts), default=0) * 0.62 * fontsize / 72.0


def figure(df, keys: Sequence[str], value: str, title: str = ""):
    """The heat map's matplotlib figure (what heat_map saves): `value` over the first two swept
    keys. The figure is sized from what it holds (cells as wide as their texts and tick
    labels, margins as wide as the labels, the legend or colour bar beside the axes), so that
    no two texts overlap for any grid. Raises as heat_map."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    keys = [k for k in keys if k in df.columns]
    if not keys:
        raise ValueError("a heat map needs at least one swept key")
    if value not in df.columns:
        raise ValueError(f"no column {value!r} (columns: {', '.join(df.columns)})")
    kx = keys[0]
    ky = keys[1] if len(keys) > 1 else None
    xs = sorted(df[kx].dropna().unique())
    ys = sorted(df[ky].dropna().unique()) if ky else [None]
    first = df.drop_duplicates([kx] + ([ky] if ky else []))
    cell = {(r[kx], r[ky] if ky else None): r for _, r in first.iterrows()}
    texts = {}
    if value == "status":
        names = sorted(set(df["status"]), key=lambda s: (s != "ok", s))
        code = {s: i for i, s in enumerate(names)}
        grid = np.full((len(ys), len(xs)), np.nan)
        for (x, y), r in cell.items():
            grid[ys.index(y), xs.index(x)] = code[r["status"]]
            if "steps" in df.columns:   # how far each variant got: the steps it took
                texts[ys.index(y), xs.index(x)] = (f"{int(r['steps'])} steps", "white")
    else:
        grid = np.full((len(ys), len(xs)), np.nan)
        for (x, y), r in cell.items():
            v = r[value]
            grid[ys.index(y), xs.index(x)] = v if isinstance(v, (int, float)) and \
                math.isfinite(v) and r["status"] == "ok" else np.nan
        for i in range(len(ys)):
            for j in range(len(xs)):
                ok = math.isfinite(grid[i, j])
                texts[i, j] = ("%.3g" % grid[i, j] if ok else "failed",
                               "white" if ok else "black")
    # Layout in inches: cells fit their text (7 pt) and the x tick labels (10 pt).
    xlabels = [_label(x) for x in xs]
    ylabels = [_label(y) for y in ys] if ky else []
    cell_w = max(0.8, _text_width([t for t, _ in texts.values()], 7) + 0.2,
                 _text_width(xlabels, 10) + 0.2)
    cell_h = 0.55
    ax_w, ax_h = cell_w * len(xs), max(cell_h * len(ys), 0.6)
    left = 0.3 + _text_width(ylabels, 10) + (0.3 if ky else 0.0)
    side = 0.25 + (_text_width(["estimated", "stable step"] + [str(n) for n in set(df["status"])],
                               10) + 0.6 if value == "status" else 1.3)
    bottom, top = 0.75, 0.45
    fig_w = left + max(ax_w, _text_width([kx], 10) * 0.6) + side
    fig_h = bottom + ax_h + top
    fig = plt.figure(figsize=(fig_w, fig_h), dpi=110)
    ax = fig.add_axes([left / fig_w, bottom / fig_h, ax_w / fig_w, ax_h / fig_h])
    if value == "status":
        cmap = ListedColormap([STATUS_COLORS.get(s, "#bbbbbb") for s in names])
        ax.imshow(grid, cmap=cmap, vmin=-0.5, vmax=len(names) - 0.5, origin="lower",
                  aspect="auto")
        handles = [Patch(color=STATUS_COLORS.get(s, "#bbbbbb"), label=s) for s in names]
        handles += _stable_step_marks(ax, df, kx, ky, xs, ys)
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.03, 1.0),
                  borderaxespad=0.0, frameon=False)
    else:
        im = ax.imshow(grid, cmap="viridis", origin="lower", aspect="auto")
        cax = fig.add_axes([(left + ax_w + 0.15) / fig_w, bottom / fig_h, 0.15 / fig_w,
                            ax_h / fig_h])
        fig.colorbar(im, cax=cax, label=value)
    for (i, j), (txt, color) in texts.items():
        ax.text(j, i, txt, ha="center", va="center", fontsize=7, color=color)
    ax.set_xticks(range(len(xs)), xlabels)
    ax.set_xlabel(kx)
    if ky:
        ax.set_yticks(range(len(ys)), ylabels)
        ax.set_ylabel(ky)
    else:
        ax.set_yticks([])
    ax.set_title(title or value, fontsize=10)
    return fig


def heat_map(df, keys: Sequence[str], value: str, path: Union[str, Path], title: str = "") -> Path:
    """Draws `value` (the "status" column, or a numeric one) over the first two swept keys
    (x: the first, y: the second; one key gives a single row) into `path` (PNG). Cells that hold
    several variants (other keys swept too) show the first. Raises ValueError without a swept
    key or for an unknown column, ImportError without matplotlib."""
    import matplotlib.pyplot as plt
    fig = figure(df, keys, value, title)
    path = Path(path)
    # "tight" keeps whatever reaches past the estimated margins (a long key name) in the picture.
    fig.savefig(path, bbox_inches="tight", pad_inches=0.1)
    plt.close(fig)
    return path
