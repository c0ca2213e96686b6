# SPDX-License-Identifier: MIT
"""The --plot heat map's layout (issue 28, 9): no two texts overlap, every cell's text fits its
cell, and the legend or colour bar stays beside the axes, for a 2 x 2 grid (whose labels
overlapped) and others."""
from __future__ import annotations

import itertools

import pytest

pytest.importorskip("matplotlib", reason="matplotlib is not installed: pip install "
                    "'./bindings/python[sweep]'")
pd = pytest.importorskip("pandas", reason="pandas is not installed")

from defsim.sweep._plot import figure, heat_map  # noqa: E402

E = "bodies.0.material.youngs_modulus"


def _sweep(es, hs):
    rows = []
    for e in es:
        for h in hs:
            ok = not (e == es[-1] and h == hs[-1])
            rows.append({E: e, "world.h": h, "status": "ok" if ok else "unstable",
                         "steps": 120 if ok else 17, "stable_step": 0.0021,
                         "metric_sag": 0.1 * e / es[-1] if ok else float("nan")})
    return pd.DataFrame(rows)


def _check_layout(fig):
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    ax = fig.axes[0]
    labels = [t for t in ax.get_xticklabels() + ax.get_yticklabels() if t.get_text()]
    labels += [t for t in (ax.xaxis.label, ax.yaxis.label, ax.title) if t.get_text()]
    cells = [t for t in ax.texts]
    legend = ax.get_legend()
    others = [legend.get_window_extent(r)] if legend else []
    others += [a.get_window_extent(r) for a in fig.axes[1:]]          # the colour bar
    others += [a.yaxis.label.get_window_extent(r) for a in fig.axes[1:]]
    boxes = [(t.get_text(), t.get_window_extent(r)) for t in labels + cells]
    boxes += [("legend or colour bar", b) for b in others]
    for (na, a), (nb, b) in itertools.combinations(boxes, 2):
        assert not a.overlaps(b), f"{na!r} overlaps {nb!r}"
    # Each cell's text inside its cell (data coordinates: cells are 1 wide, centred on j, i).
    to_data = ax.transData.inverted()
    for t in cells:
        (x0, y0), (x1, y1) = to_data.transform(t.get_window_extent(r).get_points())
        j, i = t.get_position()
        assert j - 0.5 < x0 < x1 < j + 0.5 and i - 0.5 < y0 < y1 < i + 0.5, t.get_text()
    # Nothing sticks into the axes (the legend and colour bar are beside it).
    for b in others[:1 + len(fig.axes[1:])]:
        assert not ax.get_window_extent(r).overlaps(b)
    return len(cells)


@pytest.mark.parametrize("value", ["status", "metric_sag"])
@pytest.mark.parametrize("es,hs", [
    ([1e6, 1e7], [0.0008333333333333334, 0.0033333333333333335]),       # the 2 x 2 of the issue
    ([1e5, 1e6, 1e7, 1e8], [1 / 2400, 1 / 1200, 1 / 600, 1 / 300, 1 / 150]),
    ([123456.789, 2.5e-7], [1e-3]),
])
def test_heat_map_texts_do_not_overlap(es, hs, value):
    import matplotlib.pyplot as plt
    df = _sweep(es, hs)
    fig = figure(df, [E, "world.h"], value, title=f"cantilever: {value}")
    try:
        assert _check_layout(fig) == len(es) * len(hs)
    finally:
        plt.close(fig)


def test_heat_map_one_key_and_the_png(tmp_path):
    import matplotlib.pyplot as plt
    df = _sweep([1e5, 1e6, 1e7], [1e-3])
    fig = figure(df, [E], "status")
    try:
        assert _check_layout(fig) == 3
    finally:
        plt.close(fig)
    png = heat_map(_sweep([1e6, 1e7], [1e-3, 2e-3]), [E, "world.h"], "status",
                   tmp_path / "sweep.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000
