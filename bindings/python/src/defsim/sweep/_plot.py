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


def heat_map(df, keys: Sequence[str], value: str, path: Union[str, Path], title: str = "") -> Path:
    """Draws `value` (the "status" column, or a numeric one) over the first two swept keys
    (x: the first, y: the second; one key gives a single row) into `path` (PNG). Cells that hold
    several variants (other keys swept too) show the first. Raises ValueError without a swept
    key or for an unknown column, ImportError without matplotlib."""
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
    fig, ax = plt.subplots(figsize=(1.2 + 1.1 * len(xs), 1.3 + 0.55 * len(ys)), dpi=110)
    if value == "status":
        names = sorted(set(df["status"]), key=lambda s: (s != "ok", s))
        code = {s: i for i, s in enumerate(names)}
        grid = np.full((len(ys), len(xs)), np.nan)
        for (x, y), r in cell.items():
            grid[ys.index(y), xs.index(x)] = code[r["status"]]
        cmap = ListedColormap([STATUS_COLORS.get(s, "#bbbbbb") for s in names])
        ax.imshow(grid, cmap=cmap, vmin=-0.5, vmax=len(names) - 0.5, origin="lower",
                  aspect="auto")
        # How far each variant got: the steps it took.
        if "steps" in df.columns:
            for (x, y), r in cell.items():
                ax.text(xs.index(x), ys.index(y), f"{int(r['steps'])} steps", ha="center",
                        va="center", fontsize=7, color="white")
        handles = [Patch(color=STATUS_COLORS.get(s, "#bbbbbb"), label=s) for s in names]
        handles += _stable_step_marks(ax, df, kx, ky, xs, ys)
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    else:
        grid = np.full((len(ys), len(xs)), np.nan)
        for (x, y), r in cell.items():
            v = r[value]
            grid[ys.index(y), xs.index(x)] = v if isinstance(v, (int, float)) and \
                math.isfinite(v) and r["status"] == "ok" else np.nan
        im = ax.imshow(grid, cmap="viridis", origin="lower", aspect="auto")
        fig.colorbar(im, ax=ax, label=value)
        for i in range(len(ys)):
            for j in range(len(xs)):
                txt = "%.3g" % grid[i, j] if math.isfinite(grid[i, j]) else "failed"
                ax.text(j, i, txt, ha="center", va="center", fontsize=7,
                        color="white" if math.isfinite(grid[i, j]) else "black")
    ax.set_xticks(range(len(xs)), [_label(x) for x in xs])
    ax.set_xlabel(kx)
    if ky:
        ax.set_yticks(range(len(ys)), [_label(y) for y in ys])
        ax.set_ylabel(ky)
    else:
        ax.set_yticks([])
    ax.set_title(title or value, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path)
    plt.close(fig)
    return path
