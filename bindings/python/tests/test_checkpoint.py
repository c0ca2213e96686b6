# SPDX-License-Identifier: MIT
"""Checkpoints from Python: World.save/load, to_bytes/from_bytes and pickling continue a run
bit for bit; damaged checkpoints raise FileError."""
from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

import defsim
from conftest import world_or_skip


def scene(backend: str) -> defsim.World:
    """A clamped, damped beam with a spring rope attached to its tip, under gravity and held
    external forces."""
    w = world_or_skip(backend, gravity=(0, -9.81, 0), num_threads=1)
    mat = defsim.Material("stable_neohookean", youngs_modulus=2e5, mass_damping=0.2,
                          stiffness_damping=1e-3)
    beam = w.add_body(defsim.mesh_box((0, 0, 0), (1.0, 0.2, 0.2), cells=(4, 1, 1)),
                      material=mat)
    beam.pin(beam.positions[:, 0] <= 0.0)
    rope = w.add_body(defsim.mesh_rope((1.2, 0, 0), (1.8, 0, 0), 6),
                      material=defsim.Material("spring", stiffness=300.0, vertex_mass=0.02))
    w.add_attachment(rope, 0, target_body=beam, target_vertices=[4], target_weights=[1.0],
                     stiffness=500.0)
    f = np.zeros((w.vertex_count, 3))
    f[rope.vertices, 2] = 0.05
    w.set_external_forces(f)
    return w


def same_state(a: defsim.World, b: defsim.World) -> bool:
    return (a.positions.tobytes() == b.positions.tobytes()
            and a.velocities.tobytes() == b.velocities.tobytes() and a.time == b.time)


@pytest.mark.parametrize("backend", ["symplectic_euler", "velocity_verlet", "bdf2",
                                     "sundials_ida"])
def test_save_load_continues_bit_for_bit(backend: str, tmp_path: "os.PathLike[str]") -> None:
    a = scene(backend)
    a.step(1e-3, 12)
    path = os.path.join(tmp_path, "w.dfck")
    a.save(path)
    b = defsim.World.load(path)
    assert same_state(a, b)
    assert b.backend == backend and b.gravity == a.gravity
    assert [x.vertex_count for x in b.bodies] == [x.vertex_count for x in a.bodies]
    assert len(b.attachments()) == 1
    assert b.stats().steps == 12
    a.step(1e-3, 12)
    b.step(1e-3, 12)
    assert same_state(a, b)
    assert a.stats().force_evals == b.stats().force_evals


def test_pickle(tmp_path: "os.PathLike[str]") -> None:
    a = scene("symplectic_euler")
    a.step(1e-3, 5)
    b = pickle.loads(pickle.dumps(a))
    assert isinstance(b, defsim.World) and b is not a
    assert same_state(a, b)
    # The loaded world knows its bodies' tets: element stress works as on the original.
    sa, sb = a.bodies[0].element_stress(), b.bodies[0].element_stress()
    assert np.array_equal(sa.von_mises, sb.von_mises)
    a.step(1e-3, 5)
    b.step(1e-3, 5)
    assert same_state(a, b)
    # Bytes round trip: the same bytes again.
    assert defsim.World.from_bytes(b.to_bytes()).to_bytes() == b.to_bytes()


def test_damaged_bytes_raise() -> None:
    a = scene("symplectic_euler")
    data = a.to_bytes()
    with pytest.raises(defsim.FileError, match="truncated"):
        defsim.World.from_bytes(data[:-1])
    bad = bytearray(data)
    bad[len(bad) // 2] ^= 0x01
    with pytest.raises(defsim.FileError, match="CRC"):
        defsim.World.from_bytes(bytes(bad))
    with pytest.raises(defsim.FileError, match="not a defsim checkpoint"):
        defsim.World.from_bytes(b"hello")


def test_save_failure_keeps_old_file(tmp_path: "os.PathLike[str]") -> None:
    a = scene("symplectic_euler")
    path = os.path.join(tmp_path, "w.dfck")
    a.save(path)
    before = open(path, "rb").read()
    with pytest.raises(defsim.FileError):
        a.save(os.path.join(tmp_path, "no", "such", "dir.dfck"))
    assert open(path, "rb").read() == before
    assert sorted(os.listdir(tmp_path)) == ["w.dfck"]
