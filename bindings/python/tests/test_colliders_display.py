# SPDX-License-Identifier: MIT
"""Colliders from Python, cloth stiffness by spring kind, and the rendered display."""
from __future__ import annotations

import os
import struct
import zlib

import numpy as np
import pytest

import defsim
import defsim.display
import defsim.io

from conftest import world_or_skip


def test_collider_api(world):
    world.add_body(np.zeros((1, 3)), material=defsim.Material("spring", vertex_mass=1.0))
    ball = world.add_collider("sphere", radius=0.5, position=(0, -1, 0), friction=0.25)
    ground = world.add_collider()
    assert world.colliders == [ball, ground]
    assert ball.shape == defsim.Shape.SPHERE and ground.shape == defsim.Shape.PLANE
    assert ball.friction == 0.25
    assert ball.pose == defsim.Pose((0.0, -1.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    forces = world.contact_forces()
    assert forces.shape == (1, 3) and not forces.any()       # zero before any step
    with pytest.raises(defsim.InvalidArgumentError):
        world.add_collider("sphere", radius=-1.0)
    with pytest.raises(defsim.InvalidArgumentError):
        world.add_collider("teapot")
    with pytest.raises(defsim.InvalidArgumentError):
        ball.set_pose((0, 0, 0), rotation=(2, 0, 0, 0))     # not a unit quaternion
    ball.remove()
    assert world.colliders == [ground] and not ball.alive
    with pytest.raises(defsim.StaleIdError):
        ball.set_pose((0, 0, 0))
    with pytest.raises(defsim.StaleIdError):
        world.remove_collider(ball)
    with defsim.World() as other:
        with pytest.raises(defsim.StaleIdError):
            other.remove_collider(ground)


SQ = np.sqrt(0.5)


@pytest.mark.parametrize("shape,kw,top,x0", [
    ("plane", {}, 0.0, 0.0),
    ("sphere", {"radius": 0.3}, 0.3, 0.0),
    ("box", {"half_extents": (0.5, 0.25, 0.5)}, 0.25, 0.1),
    ("capsule", {"radius": 0.2, "half_height": 0.3}, 0.5, 0.0),             # axis along y
    ("capsule", {"radius": 0.2, "half_height": 0.3, "rotation": (SQ, 0, 0, SQ)}, 0.2, 0.25),
    ("mesh", {"vertices": [[-1, 0.2, -1], [1, 0.2, -1], [1, 0.2, 1], [-1, 0.2, 1]],
              "triangles": [[0, 2, 1], [0, 3, 2]]}, 0.2, 0.1),
])
def test_every_shape_carries_a_resting_vertex(shape, kw, top, x0):
    # docs/python.md, "Colliders" (issue 28, 4): box, capsule and mesh work like plane and
    # sphere. A damped vertex of 0.5 kg dropped 0.1 m onto each comes to rest just above the
    # surface (inside the barrier's reach, 1e-3 m) with a contact force equal to its weight.
    with world_or_skip("newton_cholmod", gravity=(0, -9.81, 0)) as w:
        w.add_body([[x0, top + 0.1, 0.0]],
                   material=defsim.Material("spring", vertex_mass=0.5, mass_damping=20.0))
        w.add_collider(shape, **kw)
        w.step(1e-3, steps=600)
        gap = w.positions[0, 1] - top
        f = w.contact_forces()[0]
    assert 0.0 < gap < 1e-3, gap
    assert f[1] == pytest.approx(0.5 * 9.81, rel=1e-6) and abs(f[0]) + abs(f[2]) < 1e-9, f


def test_the_docs_name_every_shape_the_library_accepts():
    # docs/python.md said the library accepts plane and sphere and refuses the others.
    doc = os.path.join(os.path.dirname(__file__), *[os.pardir] * 3, "docs", "python.md")
    if not os.path.isfile(doc):
        pytest.skip("not a source tree")
    with open(doc, encoding="utf-8") as f:
        text = f.read()
    section = text[text.index("## Colliders"):]
    section = section[:section.index("\n## ", 1)]
    assert "refused" not in section.replace("unknown shape", "")
    for shape in ("plane", "sphere", "box", "capsule", "mesh"):
        assert f"`{shape}`" in section or f'"{shape}"' in section, shape


def test_cloth_stiffness_by_kind():
    """Each kind gets its stiffness: a uniform stretch by (1 + e) stores e^2/2 sum k l0^2 with
    the rest lengths summed by kind here."""
    cloth = defsim.mesh_cloth((0, 0, 0), (0.6, 0, 0), (0, 0, -0.4), 3, 4)
    kinds = cloth.spring_kinds
    assert kinds is not None and kinds.shape == (cloth.spring_count,)
    assert set(np.unique(kinds)) == {defsim.SpringKind.STRETCH, defsim.SpringKind.SHEAR,
                                     defsim.SpringKind.BEND}
    l2 = ((cloth.positions[cloth.springs[:, 0]] - cloth.positions[cloth.springs[:, 1]]) ** 2).sum(1)
    k = {defsim.SpringKind.STRETCH: 300.0, defsim.SpringKind.SHEAR: 40.0, defsim.SpringKind.BEND: 5.0}
    e = 0.01
    want = 0.5 * e * e * sum(k[kind] * l2[kinds == kind].sum() for kind in k)
    with defsim.World(gravity=(0, 0, 0)) as w:
        w.add_body(cloth, material=defsim.Material("spring", stiffness=300, vertex_mass=0.01),
                   shear_stiffness=40, bend_stiffness=5)
        w.positions = cloth.positions * (1 + e)
        assert w.energy().elastic == pytest.approx(want, rel=1e-12)
        # Explicit kinds on plain arrays; conflicting or incomplete arguments are errors.
        b = w.add_body(cloth.positions, springs=cloth.springs, spring_kinds=kinds,
                       material=defsim.Material("spring", stiffness=300, vertex_mass=0.01),
                       bend_stiffness=0.0)
        assert b.vertex_count == cloth.vertex_count
        with pytest.raises(defsim.InvalidArgumentError):
            w.add_body(cloth.positions, springs=cloth.springs, shear_stiffness=1.0,
                       material=defsim.Material("spring", vertex_mass=0.01))
        with pytest.raises(defsim.InvalidArgumentError):
            w.add_body(cloth, spring_kinds=kinds, spring_stiffness=np.ones(cloth.spring_count),
                       material=defsim.Material("spring", vertex_mass=0.01))
        with pytest.raises(defsim.InvalidMeshError):
            w.add_body(cloth, spring_kinds=np.full(cloth.spring_count, 9),
                       material=defsim.Material("spring", vertex_mass=0.01))
    rope = defsim.mesh_rope((0, 0, 0), (1, 0, 0), 4)
    assert rope.spring_kinds.tolist() == [0] * 4 + [2] * 3


def _png_size(png: bytes):
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = struct.unpack(">II", png[16:24])
    return width, height


def _png_pixels(png: bytes, width: int, height: int) -> np.ndarray:
    """RGB8 pixels of a non-interlaced PNG with filter-free or sub/up/avg/paeth rows."""
    data, pos = b"", 8
    while pos < len(png):
        n, kind = struct.unpack(">I4s", png[pos:pos + 8])
        if kind == b"IDAT":
            data += png[pos + 8:pos + 8 + n]
        pos += 12 + n
    raw = zlib.decompress(data)
    stride = 3 * width
    out = np.zeros((height, stride), np.int32)
    prev = np.zeros(stride, np.int32)
    for y in range(height):
        f = raw[y * (stride + 1)]
        row = np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int32)
        cur = np.zeros(stride, np.int32)
        for i in range(stride):
            a = cur[i - 3] if i >= 3 else 0
            b = prev[i]
            c = prev[i - 3] if i >= 3 else 0
            if f == 0:
                p = 0
            elif f == 1:
                p = a
            elif f == 2:
                p = b
            elif f == 3:
                p = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[i] = (row[i] + p) & 255
        out[y] = cur
        prev = cur
    return out.reshape(height, width, 3)


def test_display_png():
    if not defsim.display.available():
        pytest.skip("libdefsim_render is not built (OSMesa or libpng missing)")
    with defsim.World() as w:
        assert w._repr_png_() is None                            # nothing to draw
        w.add_body(defsim.mesh_box((0, 0, 0), (1, 0.2, 0.2), cells=(4, 1, 1)),
                   material=defsim.Material("corotated", youngs_modulus=1e5, poisson_ratio=0.3,
                                            density=1000))
        png = w._repr_png_()
        assert _png_size(png) == (640, 400)
        small = defsim.display.render_png(w, 96, 64)
        px = _png_pixels(small, 96, 64)
        # The first body's colour (orange: red above blue) covers some pixels in the middle.
        centre = px[20:44, 24:72].reshape(-1, 3)
        assert ((centre[:, 0] > centre[:, 2] + 60)).sum() > 50
        with pytest.raises(defsim.InvalidArgumentError):
            defsim.display.render_png(w, 4, 4)
    assert w._repr_png_() is None                                # closed
    scene = defsim.io.load_scene(os.path.join(os.path.dirname(__file__), "..", "..", "..",
                                              "tests", "scenes", "rope.json"))
    assert _png_size(scene._repr_png_()) == (640, 400)           # a scene shows its world


def test_sdf_trampoline():
    """A Python SDF as the library calls it: distance returned, gradient written, and an
    exception turned into NaN (which fails the step) and kept for StepError's __cause__."""
    from defsim._collider import _Sdf
    from defsim._native import ffi
    cb = _Sdf(lambda p: (p[1] - 0.5, (0.0, 2.0 * p[1], 0.0)))
    p = ffi.new("double[3]", [1.0, 2.0, 3.0])
    grad = ffi.new("double[3]")
    assert cb.c_fn(ffi.NULL, p, grad) == 1.5
    assert list(grad) == [0.0, 4.0, 0.0]
    boom = _Sdf(lambda p: 1 / 0)
    assert np.isnan(boom.c_fn(ffi.NULL, p, grad))
    assert isinstance(boom.error, ZeroDivisionError)
    short = _Sdf(lambda p: (0.0, (1.0, 0.0)))        # a gradient of two numbers
    assert np.isnan(short.c_fn(ffi.NULL, p, grad)) and short.error is not None
