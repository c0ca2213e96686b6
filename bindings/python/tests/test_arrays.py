# SPDX-License-Identifier: MIT
"""Round trips of arrays between numpy and the library: shapes, dtypes, copies, offsets."""
from __future__ import annotations

import numpy as np
import pytest

import defsim
from conftest import perturbed


def test_mesh_box_arrays() -> None:
    lo, hi, (nx, ny, nz) = (-1.0, 0.0, 2.0), (1.0, 0.5, 3.0), (4, 2, 3)
    m = defsim.mesh_box(lo, hi, cells=(nx, ny, nz))
    nv = (nx + 1) * (ny + 1) * (nz + 1)
    assert m.positions.shape == (nv, 3) and m.positions.dtype == np.float64
    assert m.tets.shape == (6 * nx * ny * nz, 4) and m.tets.dtype == np.int32
    assert m.triangles.shape[1] == 3 and m.triangles.dtype == np.int32
    # Boundary: 2 triangles per cell face on the surface.
    assert m.triangle_count == 4 * (nx * ny + ny * nz + nx * nz)
    assert m.springs.shape == (0, 2)
    # Vertex i + (nx+1)(j + (ny+1) k) sits on the grid.
    k, j, i = np.meshgrid(np.arange(nz + 1), np.arange(ny + 1), np.arange(nx + 1), indexing="ij")
    expect = np.stack([lo[0] + (hi[0] - lo[0]) * i / nx, lo[1] + (hi[1] - lo[1]) * j / ny,
                       lo[2] + (hi[2] - lo[2]) * k / nz], axis=-1).reshape(-1, 3)
    np.testing.assert_allclose(m.positions, expect, rtol=0, atol=1e-15)
    # Every tet positively oriented, and the tets fill the box.
    p = m.positions[m.tets]
    det = np.linalg.det(np.stack([p[:, 0] - p[:, 3], p[:, 1] - p[:, 3], p[:, 2] - p[:, 3]], -1))
    assert np.all(det > 0)
    assert np.isclose(det.sum() / 6, np.prod(np.subtract(hi, lo)))
    # The arrays belong to the Mesh (the C mesh was freed): writable, own their data.
    assert m.positions.flags.writeable and m.positions.base is None
    assert defsim.mesh_box(cells=2).tet_count == 48


def test_state_round_trip_is_exact(world: defsim.World, box: defsim.Mesh) -> None:
    world.add_body(box)
    x = perturbed(box.positions, 0.01)
    v = perturbed(np.zeros_like(x), 2.0, seed=2)
    world.set_state(x, v)
    assert np.array_equal(world.positions, x) and np.array_equal(world.velocities, v)
    # Flat arrays and lists are accepted and mean the same.
    world.positions = list(x.reshape(-1) * 2)
    assert np.array_equal(world.positions, 2 * x)
    world.velocities = np.asfortranarray(v * 3)
    assert np.array_equal(world.velocities, 3 * v)
    # set_state(None, ...) leaves positions alone.
    world.set_state(velocities=v)
    assert np.array_equal(world.positions, 2 * x) and np.array_equal(world.velocities, v)


def test_positions_are_copies(world: defsim.World, box: defsim.Mesh) -> None:
    world.add_body(box)
    x = world.positions
    x[:] = 99.0
    assert np.array_equal(world.positions, box.positions)
    box.positions[:] = -1.0   # the world copied the mesh too
    assert np.all(world.positions >= 0.0)


def test_get_positions_into_a_buffer(world: defsim.World, box: defsim.Mesh) -> None:
    world.add_body(box)
    out = np.full((box.vertex_count, 3), np.nan)
    assert world.get_positions(out) is out
    assert np.array_equal(out, box.positions)
    flat = np.zeros(3 * box.vertex_count)
    world.step(1e-3)
    world.get_velocities(flat)
    assert np.array_equal(flat.reshape(-1, 3), world.velocities)
    for bad in (np.zeros((box.vertex_count, 3), dtype=np.float32),
                np.zeros((box.vertex_count, 4)),
                np.zeros((3, box.vertex_count)).T,              # not C-contiguous
                [[0.0, 0.0, 0.0]] * box.vertex_count):          # not an ndarray
        with pytest.raises(defsim.InvalidArgumentError):
            world.get_positions(bad)


def test_masses_match_density_and_volume(world: defsim.World, box: defsim.Mesh) -> None:
    world.add_body(box, material=defsim.Material("stvk", density=750.0))
    m = world.masses
    assert m.shape == (box.vertex_count,)
    assert np.isclose(m.sum(), 750.0 * 0.4 * 0.2 * 0.2, rtol=1e-12)
    # Explicit per-vertex masses come back exactly.
    chain = np.array([[0, 1, 0], [0.1, 1, 0], [0.2, 1, 0]], dtype=float)
    mass = np.array([0.5, 0.25, 0.125])
    world.add_body(chain, springs=[[0, 1], [1, 2]], vertex_mass=mass,
                   material=defsim.Material("spring"))
    assert np.array_equal(world.masses[box.vertex_count:], mass)


def test_bodies_offsets_and_removal(world: defsim.World, box: defsim.Mesh) -> None:
    a = world.add_body(box)
    b = world.add_body(box.positions + [1.0, 0.0, 0.0], tets=box.tets.astype(np.int64))
    c = world.add_body([[5.0, 5.0, 5.0]], material=defsim.Material("spring"))
    assert world.bodies == [a, b, c] and len(world) == 3
    assert (a.vertex_offset, b.vertex_offset, c.vertex_offset) == (0, 12, 24)
    assert b.vertices == slice(12, 24) and world.vertex_count == 25
    assert np.array_equal(b.positions, box.positions + [1.0, 0.0, 0.0])
    world.step(1e-3, steps=3)
    before, bid = world.positions, b.id
    a.remove()
    assert not a.alive and b.alive and world.bodies == [b, c]
    assert (b.vertex_offset, c.vertex_offset) == (0, 12)
    # Later bodies keep their state, moved down.
    assert np.array_equal(world.positions, before[12:])
    assert hash(b) == hash(world.bodies[0]) and b.id == bid


def test_initial_state_and_spring_stiffness(world: defsim.World) -> None:
    rest = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], dtype=float)
    x0 = rest * 1.5
    v0 = np.array([[0, 1, 0], [0, 2, 0], [0, 3, 0]], dtype=float)
    world.add_body(rest, springs=[0, 1, 1, 2], spring_stiffness=[10.0, 20.0],
                   initial_positions=x0, initial_velocities=v0,
                   material=defsim.Material("spring", vertex_mass=2.0))
    assert np.array_equal(world.positions, x0) and np.array_equal(world.velocities, v0)
    # Springs stretched by 0.5 m each: E = 1/2 (10 + 20) 0.25.
    assert world.energy().elastic == pytest.approx(0.5 * 30.0 * 0.25, rel=1e-14)
    # Forces: -k (l - l0) along each spring.
    np.testing.assert_allclose(world.forces(), [[5, 0, 0], [5, 0, 0], [-10, 0, 0]], atol=1e-12)


def test_material_eval_batches(world: defsim.World) -> None:
    mat = defsim.Material("corotated", youngs_modulus=1e5, poisson_ratio=0.3)
    rng = np.random.default_rng(3)
    F = np.eye(3) + 0.1 * rng.standard_normal((4, 2, 3, 3))
    r = defsim.material_eval(mat, F)
    assert r.psi.shape == (4, 2) and r.P.shape == (4, 2, 3, 3) and r.dPdF.shape == (4, 2, 3, 3, 3, 3)
    one = mat.eval(F[1, 1])
    assert isinstance(one.psi, float)
    assert one.psi == r.psi[1, 1] and np.array_equal(one.P, r.P[1, 1])
    assert np.array_equal(one.dPdF, r.dPdF[1, 1])
    only_psi = defsim.material_eval(mat, F[0, 0], stress=False, tangent=False)
    assert only_psi.P is None and only_psi.dPdF is None and only_psi.psi == r.psi[0, 0]
