# SPDX-License-Identifier: MIT
"""Zero-copy read access (issue 28): World.state_view() gives read-only numpy arrays over the
library's own state (defsim_world_state_view) that see every step, DLPack through numpy, and a
view that refuses access once the state arrays moved."""
from __future__ import annotations

import numpy as np
import pytest

import defsim


def _address(a: np.ndarray) -> int:
    return a.__array_interface__["data"][0]


@pytest.fixture
def beam(world: defsim.World, box: defsim.Mesh) -> defsim.Body:
    b = world.add_body(box, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                     poisson_ratio=0.3, density=1000))
    b.pin(box.positions[:, 0] == 0.0)
    return b


def test_view_aliases_the_state(world: defsim.World, beam: defsim.Body) -> None:
    view = world.state_view()
    x, v = view.positions, view.velocities
    assert x.shape == v.shape == (world.vertex_count, 3)
    assert x.tobytes() == world.positions.tobytes() and not v.any()
    at = _address(x)
    world.step(1e-3, steps=3)
    # the same arrays, at the same address, now hold the stepped state: no copy was made
    assert view.positions is x and _address(view.positions) == at
    assert x.tobytes() == world.positions.tobytes()
    assert v.tobytes() == world.velocities.tobytes() and np.abs(v).max() > 0.0
    moved = world.positions + 0.01
    world.set_state(positions=moved)
    assert x.tobytes() == moved.tobytes()
    free = np.flatnonzero(~(world.topology(beam).rest[:, 0] == 0.0))
    beam.pin(free[:1])
    assert not v[free[0]].any()   # pinning zeroes the velocity in place


def test_view_is_read_only(world: defsim.World, beam: defsim.Body) -> None:
    view = world.state_view()
    with pytest.raises(ValueError):
        view.positions[0, 0] = 1.0
    with pytest.raises(ValueError):
        view.velocities[:] = 0.0
    with pytest.raises(AttributeError):
        view.positions = np.zeros((3, 3))   # type: ignore[misc]
    assert world.positions[0, 0] == 0.0


def test_failed_step_leaves_the_view(world: defsim.World, beam: defsim.Body) -> None:
    view = world.state_view()
    world.step(1e-3)
    before = view.positions.copy()
    with pytest.raises(defsim.InvalidArgumentError):
        world.step(-1.0)
    assert view.positions.tobytes() == before.tobytes()


def test_view_goes_stale_when_the_arrays_move(world: defsim.World, beam: defsim.Body,
                                              box: defsim.Mesh) -> None:
    view = world.state_view()
    n = world.vertex_count
    world.step(1e-3)
    assert view.valid
    other = world.add_body(box.positions + [0, 1, 0], tets=box.tets)
    assert not view.valid
    with pytest.raises(defsim.StaleViewError) as info:
        view.positions
    assert info.value.status == defsim.Status.STALE_ID
    with pytest.raises(defsim.StaleViewError):
        view.element_stress(beam)
    fresh = world.state_view()
    assert fresh.positions.shape == (n + box.vertex_count, 3)
    world.remove_body(other)
    assert not fresh.valid
    last = world.state_view()
    assert last.positions.tobytes() == world.positions.tobytes()
    world.close()
    assert not last.valid
    with pytest.raises(defsim.StaleViewError):
        last.velocities


def test_dlpack_shares_the_memory(world: defsim.World, beam: defsim.Body) -> None:
    view = world.state_view()
    t = np.from_dlpack(view.positions)
    assert np.shares_memory(t, view.positions) and not t.flags.writeable
    assert view.positions.__dlpack_device__() == (1, 0)   # kDLCPU, device 0
    world.step(1e-3, steps=2)
    assert t.tobytes() == world.positions.tobytes()


def test_view_stress_once_per_state(world: defsim.World, beam: defsim.Body) -> None:
    view = world.state_view()
    world.step(1e-3, steps=5)
    s = view.element_stress(beam)
    ref = beam.element_stress()
    for a, b in zip(s, ref):
        assert a.tobytes() == b.tobytes() and not a.flags.writeable
    assert s.von_mises.max() > 0.0
    assert view.element_stress(beam) is s    # unchanged state: the same buffers
    vm = s.von_mises.copy()
    world.step(1e-3)
    s2 = view.element_stress(beam)
    assert s2.von_mises is s.von_mises        # the same buffers, computed again
    assert s2.von_mises.tobytes() == beam.element_stress().von_mises.tobytes()
    assert s2.von_mises.tobytes() != vm.tobytes()


def test_scene_world_view_sees_scene_steps() -> None:
    import os
    import defsim.io as dio
    here = os.path.dirname(os.path.abspath(__file__))
    s = dio.load_scene(os.path.join(here, "..", "..", "..", "tests", "scenes", "rope.json"))
    view = s.world.state_view()
    s.step(steps=3)
    assert view.positions.tobytes() == s.world.positions.tobytes()
