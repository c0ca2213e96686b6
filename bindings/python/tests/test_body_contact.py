# SPDX-License-Identifier: MIT
"""Body-body and self-contact from Python (docs/body-contact.md): the body fields and the core
option reach the library, the filter decides which pairs exist, and an explicit backend refuses
with UnsupportedError, state unchanged."""
from __future__ import annotations

import numpy as np
import pytest

import defsim
from defsim import Status


def _two_triangles(w: defsim.World, gap: float, **kwargs) -> list:
    # two unit right triangles, one above the other by `gap` (a folded cloth, in two bodies)
    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    spring = defsim.Material("spring", vertex_mass=0.1)
    a = w.add_body(tri, material=spring, triangles=[[0, 1, 2]], **kwargs)
    b = w.add_body(tri + [0.0, 0.0, gap], material=spring, triangles=[[0, 1, 2]], **kwargs)
    return [a, b]


def test_groups_decide_the_pairs() -> None:
    # gap 0.001 m = 0.7 dhat (dhat = 1e-3 x 1.414 m): every non-adjacent pair is a candidate:
    # 3 + 3 point-triangle, 9 edge-edge
    with defsim.World("newton_cholmod", gravity=(0, 0, 0),
                      options={"core.body_contact": True}) as w:
        a, b = _two_triangles(w, 0.001, friction=0.3)
        w.step(0.01)
        f = w.contact_forces()
        assert np.abs(f).max() > 0.0
        np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-12 * np.abs(f).max())
        assert w.stat("contact.body_candidates") == 15
        # merged as IPC does: each vertex over its twin is one vertex-vertex contact (the point-
        # triangle and crossing edge-edge pairs that meet there), the three pairs of parallel
        # edges stay mollified edge-edge contacts: 3 + 3
        assert w.stat("contact.body_active") == 6
        # the barrier pushed them apart, still within dhat
        assert 0.001 < w.stat("contact.body_min_distance") < 1e-3 * np.sqrt(2.0)
        b.set_collision(True, group=2, mask=2)   # b no longer collides with a's group 1
        w.step(0.01)
        assert w.stat("contact.body_candidates") == 0
        np.testing.assert_array_equal(w.contact_forces(), np.zeros((6, 3)))


def test_bad_fields_and_refusal() -> None:
    with defsim.World("symplectic_euler", options={"core.body_contact": True}) as w:
        with pytest.raises(defsim.InvalidArgumentError):
            _two_triangles(w, 0.1, collision_group=-1)
        with pytest.raises(defsim.InvalidMaterialError):
            _two_triangles(w, 0.1, friction=-1.0)
        assert len(w.bodies) == 0
    with defsim.World("symplectic_euler", options={"core.body_contact": True}) as w:
        _two_triangles(w, 0.1)
        x0 = w.positions
        with pytest.raises(defsim.UnsupportedError) as info:
            w.step(1e-3)
        assert info.value.status is Status.UNSUPPORTED
        assert "newton_cholmod" in info.value.message
        np.testing.assert_array_equal(w.positions, x0)
        assert w.time == 0.0
        w.set_option("core.body_contact", False)
        w.step(1e-3)
        assert w.time == 1e-3
