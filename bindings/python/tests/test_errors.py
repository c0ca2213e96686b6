# SPDX-License-Identifier: MIT
"""Every error path raises the Error subclass of its status code, carries the code, and leaves
the world as it was."""
from __future__ import annotations

import pickle

import numpy as np
import pytest

import defsim
from defsim import Status


def _raises(cls, status, fn, *args, **kwargs) -> defsim.Error:
    with pytest.raises(cls) as info:
        fn(*args, **kwargs)
    assert isinstance(info.value, defsim.Error)
    assert info.value.status == status
    return info.value


def test_every_status_maps_to_its_class() -> None:
    expect = {
        Status.INVALID_ARGUMENT: (defsim.InvalidArgumentError, ValueError),
        Status.INVALID_MESH: (defsim.InvalidMeshError, ValueError),
        Status.INVALID_MATERIAL: (defsim.InvalidMaterialError, ValueError),
        Status.BACKEND_UNAVAILABLE: (defsim.BackendUnavailableError, defsim.Error),
        Status.NOT_CONVERGED: (defsim.NotConvergedError, defsim.Error),
        Status.UNSTABLE: (defsim.UnstableError, ArithmeticError),
        Status.OUT_OF_MEMORY: (defsim.OutOfMemoryError, MemoryError),
        Status.IO: (defsim.FileError, defsim.Error),
        Status.STALE_ID: (defsim.StaleIdError, LookupError),
        Status.LOCKED: (defsim.LockedError, defsim.Error),
        Status.CONFLICT: (defsim.ConflictError, defsim.Error),
        Status.CALLBACK: (defsim.CallbackError, defsim.Error),
        Status.UNSUPPORTED: (defsim.UnsupportedError, NotImplementedError),
    }
    assert set(expect) == set(Status) - {Status.OK}
    for status, (cls, base) in expect.items():
        e = defsim.error_from_status(int(status), "detail")
        assert type(e) is cls and isinstance(e, base) and e.status is status
        assert e.message == "detail"
        # raised from Python: the class's own code (UnsupportedError's own is None: a missing
        # C function, no call made)
        assert cls("x").status is (None if cls is defsim.UnsupportedError else status)
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is cls and back.status is status and back.message == "detail"
    unknown = defsim.error_from_status(-99, "?")
    assert type(unknown) is defsim.Error and unknown.status == -99


def test_world_creation_errors() -> None:
    _raises(defsim.BackendUnavailableError, Status.BACKEND_UNAVAILABLE, defsim.World,
            "no_such_backend")
    _raises(defsim.BackendUnavailableError, Status.BACKEND_UNAVAILABLE, defsim.World,
            "Bad-Name!")
    e = _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World,
                num_threads=-1)
    assert e.message   # the library's detail (defsim_last_error), not empty
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World,
            gravity=(0, float("nan"), 0))
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World,
            options={"core.substep_safety": 0})
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World,
            options={"core.simd": "sideways"})
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World, gravity=(0, 1))
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World, num_threads=1.5)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World, log=42)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.World, backend=3)


def test_add_body_errors_leave_the_world_unchanged(world: defsim.World, box: defsim.Mesh) -> None:
    first = world.add_body(box)
    n = world.vertex_count
    bad_index = box.tets.copy()
    bad_index[5, 2] = box.vertex_count
    flat = box.positions.copy()
    flat[:, 2] = 0.0   # every tet degenerate
    nan = box.positions.copy()
    nan[3, 1] = np.nan
    cases = [
        (defsim.InvalidMeshError, Status.INVALID_MESH, dict(vertices=box.positions, tets=bad_index)),
        (defsim.InvalidMeshError, Status.INVALID_MESH, dict(vertices=flat, tets=box.tets)),
        (defsim.InvalidMeshError, Status.INVALID_MESH, dict(vertices=nan, tets=box.tets)),
        (defsim.InvalidMeshError, Status.INVALID_MESH,     # zero-length spring
         dict(vertices=[[0, 0, 0], [0, 0, 0]], springs=[[0, 1]],
              material=defsim.Material("spring"))),
        (defsim.InvalidMeshError, Status.INVALID_MESH,     # a vertex without mass
         dict(vertices=[[0, 0, 0], [1, 0, 0]], springs=[[0, 1]],
              material=defsim.Material("spring", vertex_mass=0.0))),
        (defsim.InvalidMaterialError, Status.INVALID_MATERIAL,     # tets with springs' model
         dict(vertices=box, material=defsim.Material("spring"))),
        (defsim.InvalidMaterialError, Status.INVALID_MATERIAL,
         dict(vertices=box, vertex_mass=-np.ones(box.vertex_count))),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=np.zeros((4, 2)))),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=box.positions, tets=box.tets.astype(float))),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=box.positions, tets=box.tets.astype(np.int64) + 2**40)),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=box.positions, tets=box.tets[:, :3])),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=box, vertex_mass=np.ones(3))),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=box, initial_velocities=np.zeros((3, 3)))),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT,
         dict(vertices=box, material="corotated")),
        (defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, dict(vertices="abc")),
    ]
    x = world.positions
    for cls, status, kwargs in cases:
        _raises(cls, status, world.add_body, **kwargs)
        assert world.vertex_count == n and world.bodies == [first]
        assert np.array_equal(world.positions, x)
    world.step(1e-3)   # still usable


def test_material_errors() -> None:
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.Material, "rubber")
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.Material, 17)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.Material, "stvk",
            density="heavy")
    eye = np.eye(3)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.material_eval,
            defsim.Material("spring"), eye)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.material_eval,
            defsim.Material("stvk"), [[1, 0], [0, 1]])
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.material_eval,
            defsim.Material("stvk"), np.full((3, 3), np.inf))
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.material_eval,
            "stvk", eye)
    m = defsim.Material("neohookean")
    m.__dict__["youngs_modulus"] = 0.0   # past the checks of construction and assignment
    _raises(defsim.InvalidMaterialError, Status.INVALID_MATERIAL, defsim.material_eval, m, eye)
    _raises(defsim.UnstableError, Status.UNSTABLE, defsim.material_eval,
            defsim.Material("neohookean"), np.diag([1.0, 1.0, -1.0]))


def test_material_is_checked_when_made_and_assigned() -> None:
    """Issue 28 (5): Material(..., youngs_modulus=-1) was accepted until add_body. Every field is
    checked by the library's rules (defsim_material_check) where it is given."""
    bad = [("corotated", dict(youngs_modulus=-1.0)), ("stvk", dict(youngs_modulus=0.0)),
           ("neohookean", dict(youngs_modulus=np.inf)), ("stvk", dict(poisson_ratio=0.5)),
           ("stvk", dict(poisson_ratio=-0.1)), ("corotated", dict(poisson_ratio=np.nan)),
           ("stvk", dict(density=-1.0)), ("spring", dict(stiffness=-1.0)),
           ("stable_neohookean", dict(stiffness=np.inf)), ("spring", dict(vertex_mass=-0.01)),
           ("stvk", dict(mass_damping=-0.1)), ("stvk", dict(stiffness_damping=np.nan))]
    for model, kwargs in bad:
        (field, value), = kwargs.items()
        with pytest.raises(defsim.InvalidMaterialError, match=field) as info:
            defsim.Material(model, **kwargs)
        assert info.value.status == Status.INVALID_MATERIAL
    # The edges of the ranges are accepted, as add_body accepts them.
    ok = defsim.Material("stvk", youngs_modulus=1e-300, poisson_ratio=0.0, density=0.0,
                         stiffness=0.0, vertex_mass=0.0, mass_damping=0.0, stiffness_damping=0.0)
    assert ok.poisson_ratio == 0.0
    defsim.Material("corotated", poisson_ratio=np.nextafter(0.5, 0.0))
    # Assignment is checked too, and a refused value leaves the material as it was.
    m = defsim.Material("corotated", youngs_modulus=1e5)
    with pytest.raises(defsim.InvalidMaterialError, match="youngs_modulus"):
        m.youngs_modulus = -1.0
    assert m.youngs_modulus == 1e5
    with pytest.raises(defsim.InvalidArgumentError):
        m.density = "heavy"
    assert m.density == 1000.0
    m.poisson_ratio = 0.45
    assert m.poisson_ratio == 0.45
    with pytest.raises(AttributeError):
        m.young = 1.0   # a misspelt field is not silently a new attribute
    with pytest.raises(defsim.InvalidArgumentError):
        m.model = "rubber"


def test_mesh_errors() -> None:
    for kwargs in (dict(cells=0), dict(cells=(1, 1)), dict(cells=(1, -1, 1)),
                   dict(lo=(0, 0, 0), hi=(1, 0, 1)), dict(hi=(1, np.inf, 1)),
                   dict(cells=2**31), dict(cells=True), dict(lo=(0, 0))):
        _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, defsim.mesh_box, **kwargs)


def test_step_errors_leave_the_state(world: defsim.World, box: defsim.Mesh) -> None:
    world.add_body(box)
    world.step(1e-3, steps=2)
    x, v, t = world.positions, world.velocities, world.time
    for h in (0.0, -1e-3, float("nan"), float("inf")):
        _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.step, h)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.step, "1e-3")
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.step, 1e-3, -1)
    assert np.array_equal(world.positions, x) and np.array_equal(world.velocities, v)
    assert world.time == t and world.stats().steps == 2


def test_unstable_step_rolls_back() -> None:
    # Explicit Euler far beyond its stability limit: the state grows until it overflows, and
    # that step is refused with the state of the step before.
    with defsim.World("explicit_euler") as w:
        w.add_body(defsim.mesh_box(cells=1),
                   material=defsim.Material("corotated", youngs_modulus=1e9))
        x = w.positions
        x[0, 0] -= 0.3
        w.positions = x
        for _ in range(500):
            x, v = w.positions, w.velocities
            try:
                w.step(10.0)
            except defsim.UnstableError as e:
                assert e.status == Status.UNSTABLE and e.message
                break
        else:
            pytest.fail("explicit Euler did not blow up")
        assert np.array_equal(w.positions, x) and np.array_equal(w.velocities, v)
        assert np.all(np.isfinite(x))
        assert w.stats().failed_steps == 1


def test_state_errors(world: defsim.World, box: defsim.Mesh) -> None:
    world.add_body(box)
    x = world.positions
    bad = x.copy()
    bad[2, 2] = np.nan
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.set_state, bad)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.set_state, x[:-1])
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.set_state, None, x[:, :2])
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.forces, x[:-1])
    assert np.array_equal(world.positions, x)


def test_pin_and_id_errors(world: defsim.World, box: defsim.Mesh) -> None:
    b = world.add_body(box)
    for verts in ([box.vertex_count], [-1], [0.5], np.ones(3, dtype=bool)):
        _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.pin, b, verts)
    _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, world.pin, "body", [0])
    with defsim.World() as other:
        alien = other.add_body(box)
        _raises(defsim.StaleIdError, Status.STALE_ID, world.pin, alien, [0])
        _raises(defsim.StaleIdError, Status.STALE_ID, world.remove_body, alien)
    world.remove_body(b)
    _raises(defsim.StaleIdError, Status.STALE_ID, world.pin, b, [0])
    _raises(defsim.StaleIdError, Status.STALE_ID, world.unpin, b, [0])
    _raises(defsim.StaleIdError, Status.STALE_ID, b.remove)
    _raises(defsim.StaleIdError, Status.STALE_ID, lambda: b.vertex_count)
    _raises(defsim.StaleIdError, Status.STALE_ID, lambda: b.vertex_offset)


def test_closed_world(box: defsim.Mesh) -> None:
    w = defsim.World()
    b = w.add_body(box)
    w.close()
    assert w.closed and not b.alive
    w.close()   # twice is fine
    for fn in (lambda: w.step(1e-3), lambda: w.positions, lambda: w.energy(),
               lambda: w.add_body(box), lambda: w.pin(b, [0]), lambda: w.vertex_count,
               lambda: b.vertex_count, lambda: w.stats()):
        _raises(defsim.InvalidArgumentError, Status.INVALID_ARGUMENT, fn)
    assert "closed" in repr(w)


def test_error_message_comes_from_the_library(world: defsim.World, box: defsim.Mesh) -> None:
    bad = box.tets.copy()
    bad[7, 0] = 1000
    with pytest.raises(defsim.InvalidMeshError) as info:
        world.add_body(box.positions, tets=bad)
    assert info.value.message == world.last_error
    assert info.value.message   # non-empty detail


def test_unsupported_function_raises_only_when_called(monkeypatch) -> None:
    from defsim import _errors, _mesh
    monkeypatch.setattr(_errors, "lib", object())   # a library without any function
    with pytest.raises(defsim.UnsupportedError) as info:
        _errors.function("defsim_mesh_cloth")
    assert info.value.status is None and isinstance(info.value, NotImplementedError)
    monkeypatch.setattr(_mesh, "function", _errors.function)
    with pytest.raises(defsim.UnsupportedError):
        defsim.mesh_rope((0, 0, 0), (1, 0, 0), 4)
