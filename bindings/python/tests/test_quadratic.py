# SPDX-License-Identifier: MIT
"""Quadratic tets from Python (issue 29): mesh_box(quadratic=True), World.add_body with (m, 10)
tets, and the frame defsim.io writes: VTK_QUADRATIC_TETRA cells that meshio reads as tetra10,
with the stress of each element."""
from __future__ import annotations

import numpy as np
import pytest

import defsim


def test_quadratic_box_and_body():
    m = defsim.mesh_box((0, 0, 0), (2.0, 1.0, 1.0), cells=(2, 1, 1), quadratic=True)
    assert m.tets.shape == (12, 10)
    assert m.vertex_count == 5 * 3 * 3
    assert m.triangle_count == 4 * 2 * (2 + 2 + 1 + 1 + 2 + 2)
    # every mid-edge vertex is the middle of its edge (VTK's order 01, 12, 02, 03, 13, 23)
    edges = [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]
    p = m.positions
    for k, (a, b) in enumerate(edges):
        assert np.allclose(p[m.tets[:, 4 + k]], 0.5 * (p[m.tets[:, a]] + p[m.tets[:, b]]))
    w = defsim.World("symplectic_euler", gravity=(0, -9.81, 0))
    body = w.add_body(m, material=defsim.Material("stable_neohookean", youngs_modulus=1e5,
                                                  poisson_ratio=0.3, density=1000))
    assert body.vertex_count == m.vertex_count
    masses = w.masses
    assert (masses > 0).all()
    assert masses.sum() == pytest.approx(2000.0, rel=1e-12)   # rho V
    w.pin(body, m.positions[:, 0] == 0.0)
    for _ in range(10):
        w.step(1e-4)
    assert np.isfinite(w.positions).all()


def test_quadratic_frame(tmp_path):
    dio = pytest.importorskip("defsim.io")
    meshio = pytest.importorskip("meshio")
    m = defsim.mesh_box((0, 0, 0), (1.0, 0.5, 0.5), cells=(2, 1, 1), quadratic=True)
    w = defsim.World("symplectic_euler")
    body = w.add_body(m, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                  poisson_ratio=0.3, density=1000))
    x = m.positions.copy()
    x[:, 0] *= 1.1   # a homogeneous stretch: every element has the same stress
    w.set_state(x)
    path = tmp_path / "q.vtu"
    dio.write_vtu(w, path)
    r = meshio.read(path)
    assert [c.type for c in r.cells] == ["tetra10"]
    assert np.array_equal(r.cells[0].data, m.tets)
    vm = np.concatenate(r.cell_data["von_mises"]).reshape(-1)
    assert vm.shape == (12,) and vm.min() > 0 and np.allclose(vm, vm[0], rtol=1e-10)


def test_quadratic_checkpoint_and_boundary(tmp_path):
    m = defsim.mesh_box((0, 0, 0), (1.0, 0.5, 0.5), cells=(2, 1, 1), quadratic=True)
    # the Python boundary of quadratic tets is the library's, triangle for triangle
    from defsim._world import tet_boundary
    assert sorted(map(tuple, tet_boundary(m.positions, m.tets))) == sorted(map(tuple, m.triangles))
    w = defsim.World("symplectic_euler", gravity=(0, -9.81, 0))
    body = w.add_body(m, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                  poisson_ratio=0.3, density=1000))
    w.pin(body, m.positions[:, 0] == 0.0)
    w.step(1e-4, steps=5)
    path = tmp_path / "q.dfck"
    w.save(path)
    w2 = defsim.World.load(path)
    assert w2.topology(w2.bodies[0]).tets.shape == (12, 10)
    w.step(1e-4, steps=5)
    w2.step(1e-4, steps=5)
    assert np.array_equal(w.positions, w2.positions)
