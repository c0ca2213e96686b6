# SPDX-License-Identifier: MIT
"""Mesh makers and loader.

mesh_box is in this library; mesh_cloth, mesh_rope and mesh_load are wrapped for the library
versions that have them. Here their argument passing and result conversion are tested with a
stand-in for the C function (it records its arguments and fills the mesh with library-allocated
arrays from defsim_mesh_box, so that the wrapper's defsim_mesh_free is the real one)."""
from __future__ import annotations

import numpy as np
import pytest

import defsim
from defsim import _errors, _mesh
from defsim._native import ffi, lib


def _fake(calls: list, status: int = 0):
    def fn(*args):
        *params, mesh = args
        calls.append([list(p) if isinstance(p, list) else p for p in params])
        assert mesh.size == ffi.sizeof("defsim_mesh")
        if status:
            return status
        return lib.defsim_mesh_box([0, 0, 0], [1, 2, 3], 1, 1, 1, mesh)
    return fn


def _install(monkeypatch, name: str, fn) -> None:
    real = _errors.function
    monkeypatch.setattr(_mesh, "function", lambda n: fn if n == name else real(n))


def test_mesh_cloth_passes_its_arguments(monkeypatch) -> None:
    calls: list = []
    _install(monkeypatch, "defsim_mesh_cloth", _fake(calls))
    m = defsim.mesh_cloth(np.array([0.0, 1.0, 0.0]), (1, 0, 0), [0, 0, 2], 4, np.int64(3))
    assert calls == [[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0], 4, 3]]
    assert m.vertex_count == 8 and m.positions[7].tolist() == [1.0, 2.0, 3.0]
    assert m.tets.shape == (6, 4) and m.triangles.shape == (12, 3)
    with pytest.raises(defsim.InvalidArgumentError):
        defsim.mesh_cloth((0, 0), (1, 0, 0), (0, 0, 1), 4, 3)
    with pytest.raises(defsim.InvalidArgumentError):
        defsim.mesh_cloth((0, 0, 0), (1, 0, 0), (0, 0, 1), 4.5, 3)
    assert len(calls) == 1


def test_mesh_rope_passes_its_arguments(monkeypatch) -> None:
    calls: list = []
    _install(monkeypatch, "defsim_mesh_rope", _fake(calls))
    defsim.mesh_rope((0, 0, 0), (0, -1, 0), 10)
    assert calls == [[[0.0, 0.0, 0.0], [0.0, -1.0, 0.0], 10]]


def test_mesh_load_passes_the_path_and_maps_errors(monkeypatch, tmp_path) -> None:
    calls: list = []
    _install(monkeypatch, "defsim_mesh_load", _fake(calls))
    defsim.mesh_load(tmp_path / "m.obj")
    defsim.mesh_load(str(tmp_path / "n.obj"))
    assert [c[0] for c in calls] == [str(tmp_path / "m.obj").encode(),
                                     str(tmp_path / "n.obj").encode()]
    with pytest.raises(defsim.InvalidArgumentError):
        defsim.mesh_load("bad\0name")
    _install(monkeypatch, "defsim_mesh_load", _fake(calls, status=int(defsim.Status.IO)))
    with pytest.raises(defsim.FileError) as info:
        defsim.mesh_load("whatever.msh")
    assert info.value.status == defsim.Status.IO


def test_cloth_rope_load_real_library(tmp_path) -> None:
    """The generators and loader of the linked library, through the binding: counts from the
    header's documented layout, positions, and an OBJ round trip into a world."""
    c = defsim.mesh_cloth((0, 0, 0), (2, 0, 0), (0, 0, 1), 4, 2)
    assert c.vertex_count == 5 * 3 and c.triangle_count == 2 * 4 * 2 and c.tet_count == 0
    # structural u + structural v + shear + bending u + bending v
    assert c.spring_count == 4 * 3 + 5 * 2 + 2 * 4 * 2 + 3 * 3 + 5 * 1
    np.testing.assert_allclose(c.positions[4 + 5 * 2], (2.0, 0.0, 1.0))
    assert c.springs.shape == (c.spring_count, 2) and c.springs.max() < c.vertex_count
    r = defsim.mesh_rope((0, 0, 0), (0, -3, 0), 3)
    assert r.vertex_count == 4 and r.spring_count == 3 + 2
    np.testing.assert_allclose(r.positions[:, 1], [0, -1, -2, -3])
    np.testing.assert_array_equal(r.springs[:3], [[0, 1], [1, 2], [2, 3]])
    obj = tmp_path / "quad.obj"
    obj.write_text("# a unit quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    m = defsim.mesh_load(obj)
    assert m.vertex_count == 4 and m.triangle_count == 2 and m.spring_count == 5
    with pytest.raises(defsim.FileError):
        defsim.mesh_load(tmp_path / "missing.obj")
    w = defsim.World("symplectic_euler", gravity=(0, -9.81, 0))
    b = w.add_body(m, material=defsim.Material("spring", stiffness=100.0, vertex_mass=0.1))
    b.pin([2, 3])
    w.step(1e-3, steps=10)
    assert w.positions[0, 1] < 0.0 and w.positions[2, 1] == 1.0


def test_mesh_into_world(world: defsim.World) -> None:
    m = defsim.mesh_box(cells=(2, 2, 2))
    b = world.add_body(m, material=defsim.Material("corotated"))
    assert b.vertex_count == 27
    # Explicit arrays override the mesh's.
    b2 = world.add_body(m, tets=m.tets[:6], material=defsim.Material("stvk", vertex_mass=0.01))
    assert b2.vertex_count == 27 and world.vertex_count == 54
