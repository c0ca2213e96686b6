# SPDX-License-Identifier: MIT
"""The same scene run from C (bitmatch.c) and from Python gives bit-identical results.

ctest passes the C program's path in DEFSIM_BITMATCH; without it (an installed package run
outside the build tree) the test is skipped.
"""
from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest

import defsim

EXE = os.environ.get("DEFSIM_BITMATCH")


def scene(backend: str, steps: int, h: float, threads: int):
    """Mirror of main() in bitmatch.c."""
    w = defsim.World(backend, gravity=(0.5, -9.81, 0.0), num_threads=threads)
    mesh = defsim.mesh_box((0, 0, 0), (0.6, 0.2, 0.2), cells=(3, 1, 1))
    beam = w.add_body(mesh, material=defsim.Material(
        "corotated", youngs_modulus=2e5, poisson_ratio=0.35, density=900, mass_damping=0.5,
        stiffness_damping=1e-4))
    w.pin(beam, mesh.positions[:, 0] == 0.0)
    chain = [[0, 1, 0], [0.1, 1, 0], [0.2, 1.05, 0], [0.3, 1, 0.02]]
    v0 = [[0.1, 0.0, -0.2 * i] for i in range(4)]
    w.add_body(chain, springs=[[0, 1], [1, 2], [2, 3]], initial_velocities=v0,
               material=defsim.Material("spring", stiffness=500, vertex_mass=0.02))
    w.step(h, steps=steps)
    return w


@pytest.mark.skipif(not EXE, reason="DEFSIM_BITMATCH (the C reference program) not set")
@pytest.mark.parametrize("backend", ["symplectic_euler", "explicit_euler"])
@pytest.mark.parametrize("threads", [1, 2])
def test_python_matches_c_bit_for_bit(backend: str, threads: int) -> None:
    steps, h = 200, 5e-4
    out = subprocess.run([EXE, backend, str(steps), repr(h), str(threads)], check=True,
                         capture_output=True, text=True, timeout=120).stdout.split()
    ref = np.array([float.fromhex(s) for s in out])
    with scene(backend, steps, h, threads) as w:
        n = w.vertex_count
        assert ref.size == 6 * n + 1
        x, v, e = w.positions, w.velocities, w.energy().total
        rest = defsim.mesh_box((0, 0, 0), (0.6, 0.2, 0.2), cells=(3, 1, 1)).positions
    # Bit for bit: compare the raw bytes, so that even -0.0 against 0.0 would fail.
    assert x.reshape(-1).tobytes() == ref[:3 * n].tobytes()
    assert v.reshape(-1).tobytes() == ref[3 * n:6 * n].tobytes()
    assert np.float64(e).tobytes() == ref[-1].tobytes()
    # And the scene did something: the beam's free end moved, the chain flew.
    assert np.abs(x[:rest.shape[0]] - rest).max() > 1e-4
    assert np.abs(v[rest.shape[0]:]).max() > 0.1
