# SPDX-License-Identifier: MIT
"""defsim.display without a notebook (issue 28): the pictures that Jupyter would show
(_repr_png_, _repr_html_, Picture) are produced, the colour modes, pins, colliders and contact
arrows change them where they should, with libdefsim_render (OSMesa) and with PyVista, and
without any renderer the display says what to install."""
from __future__ import annotations

import base64
import os
import re

import numpy as np
import pytest

import defsim
import defsim.display as dd
from test_colliders_display import _png_pixels, _png_size

W, H = 320, 200


@pytest.fixture(scope="module")
def world():
    """A beam clamped at x = 0, sagging onto a sphere collider above a ground plane."""
    w = defsim.World("symplectic_euler")
    m = defsim.mesh_box((0, 0.4, 0), (1.0, 0.6, 0.2), cells=(10, 2, 2))
    b = w.add_body(m, material=defsim.Material("corotated", youngs_modulus=1e5,
                                               poisson_ratio=0.3, density=1000, mass_damping=5))
    w.pin(b, m.positions[:, 0] == 0.0)
    w.add_collider("plane")
    w.add_collider("sphere", position=(0.8, 0.14, 0.1), radius=0.25)
    w.step(1e-4, steps=3000)
    assert np.abs(w.contact_forces()).max() > 0          # it rests on the sphere
    assert w.pinned().sum() == 9
    yield w
    w.close()


def _pixels(png):
    assert _png_size(png) == (W, H)
    return _png_pixels(png, W, H).astype(int)


def _differ(a, b):
    """Pixels with a channel apart by more than 16 (tests/render/README.md's threshold)."""
    return (np.abs(a - b).max(axis=2) > 16)


def _backend_or_skip(name):
    if name not in dd.backends():
        # ctest's test_python_pyvista sets DEFSIM_TEST_PYVISTA: there PyVista must draw.
        if name == "pyvista" and os.environ.get("DEFSIM_TEST_PYVISTA"):
            pytest.fail("DEFSIM_TEST_PYVISTA is set but pyvista cannot be imported")
        pytest.skip(f"renderer {name} is not in this install")
    return name


@pytest.mark.parametrize("backend", ["osmesa", "pyvista"])
def test_colour_modes_pins_colliders_arrows(world, backend):
    _backend_or_skip(backend)
    img = {c: _pixels(dd.render_png(world, W, H, color=c, backend=backend)) for c in dd.COLORS}
    # Each colour mode gives another picture (bodies coloured differently, a colour bar).
    for i, a in enumerate(dd.COLORS):
        for b in dd.COLORS[i + 1:]:
            assert _differ(img[a], img[b]).sum() > 200, (a, b)
    # The body colour is defsim run's first (orange: red well above blue) in body mode only.
    orange = lambda p: ((p[..., 0] > p[..., 2] + 60) & (p[..., 1] < p[..., 0])).sum()
    assert orange(img["body"]) > 300 and orange(img["stress"]) < orange(img["body"]) / 4
    # Pins: red markers, and nothing red without them.
    red = lambda p: ((p[..., 0] > 150) & (p[..., 1] < 70) & (p[..., 2] < 70)).sum()
    no_pins = _pixels(dd.render_png(world, W, H, color="stress", pins=False, backend=backend))
    assert red(img["stress"]) >= 3 and red(no_pins) == 0
    # Colliders drawn (the grey sphere) or not.
    no_col = _pixels(dd.render_png(world, W, H, color="stress", colliders=False,
                                   backend=backend))
    assert _differ(img["stress"], no_col).sum() > 300
    # Contact arrows (orange) on request: 3 mm per N, the largest (about 100 N) 0.3 m long.
    arrows = _pixels(dd.render_png(world, W, H, color="stress", contact_forces=True,
                                   arrow_scale=0.003, backend=backend))
    hue = (arrows[..., 0] > 1.15 * arrows[..., 1]) & (arrows[..., 1] > 1.5 * arrows[..., 2])
    assert (_differ(arrows, img["stress"]) & hue).sum() > 20
    # A fixed colour range changes the colours, not the geometry.
    ranged = _pixels(dd.render_png(world, W, H, color="stress", color_range=(0, 1e6),
                                   backend=backend))
    assert _differ(img["stress"], ranged).sum() > 100


def test_jupyter_reprs(world):
    if not dd.available():
        pytest.skip("no renderer in this install")
    png = world._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and _png_size(png) == (640, 400)
    page = world._repr_html_()
    m = re.search(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert m and _png_size(base64.b64decode(m.group(1))) == (640, 400)
    assert "9 pinned" in page and "2 colliders" in page
    pic = dd.Picture(world, W, H, color="displacement")
    assert pic._repr_png_() == pic.png and _png_size(pic.png) == (W, H)
    assert "displacement (m)" in pic._repr_html_()
    with pytest.raises(defsim.InvalidArgumentError):
        dd.render_png(world, color="temperature")
    with pytest.raises(defsim.InvalidArgumentError):
        dd.render_png(world, backend="povray")
    with pytest.raises(defsim.InvalidArgumentError):
        dd.render_png(world, color="stress", color_range=(1, 0))


def test_without_a_renderer(world, monkeypatch):
    """Where libdefsim_render is not in the wheel and PyVista is not installed, _repr_png_ and
    _repr_html_ give None (Jupyter shows the text repr) and render_png says what to install."""
    def missing(*a, **k):
        raise defsim.Error("no libdefsim_render", defsim.Status.BACKEND_UNAVAILABLE)
    monkeypatch.setattr(dd, "_render_lib", missing)
    monkeypatch.setattr(dd, "_has_pyvista", lambda: False)
    assert dd.backends() == [] and not dd.available()
    assert world._repr_png_() is None and world._repr_html_() is None
    with pytest.raises(defsim.Error, match="pyvista") as e:
        dd.render_png(world)
    assert e.value.status == defsim.Status.BACKEND_UNAVAILABLE
    with pytest.raises(defsim.Error, match="pyvista"):
        dd.render_png(world, backend="pyvista")
