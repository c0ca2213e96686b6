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


@pytest.mark.parametrize("name,call", [
    ("defsim_mesh_cloth", lambda: defsim.mesh_cloth((0, 0, 0), (1, 0, 0), (0, 0, 1), 2, 2)),
    ("defsim_mesh_rope", lambda: defsim.mesh_rope((0, 0, 0), (1, 0, 0), 3)),
    ("defsim_mesh_load", lambda: defsim.mesh_load("/nonexistent/defsim/mesh.obj")),
])
def test_real_library(name: str, call) -> None:
    # Libraries without the function raise UnsupportedError when it is called (import works);
    # libraries with it are tested by their own suites; here only the nonexistent file.
    if not hasattr(lib, name):
        with pytest.raises(defsim.UnsupportedError):
            call()
    elif name == "defsim_mesh_load":
        with pytest.raises(defsim.FileError):
            call()
    else:
        pytest.skip(f"{name} is available; its results are tested with the C implementation")


def test_mesh_into_world(world: defsim.World) -> None:
    m = defsim.mesh_box(cells=(2, 2, 2))
    b = world.add_body(m, material=defsim.Material("corotated"))
    assert b.vertex_count == 27
    # Explicit arrays override the mesh's.
    b2 = world.add_body(m, tets=m.tets[:6], material=defsim.Material("stvk", vertex_mass=0.01))
    assert b2.vertex_count == 27 and world.vertex_count == 54
