# SPDX-License-Identifier: MIT
"""world.forces() is minus the gradient of world.energy().elastic: central finite differences
over every degree of freedom, for every material model."""
from __future__ import annotations

import numpy as np
import pytest

import defsim
from conftest import perturbed


def _fd_check(world: defsim.World, x: np.ndarray, d: float = 1e-7) -> None:
    f = world.forces(x)
    assert np.array_equal(f, (world.set_state(x), world.forces())[1])
    fd = np.empty(x.size)
    for i in range(x.size):
        xp, xm = x.copy().reshape(-1), x.copy().reshape(-1)
        xp[i] += d
        xm[i] -= d
        world.set_state(xp)
        ep = world.energy().elastic
        world.set_state(xm)
        em = world.energy().elastic
        fd[i] = -(ep - em) / (2 * d)
    world.set_state(x)
    scale = np.abs(f).max()
    assert scale > 1.0   # the deformation is large enough to matter
    np.testing.assert_allclose(f.reshape(-1), fd, rtol=0, atol=2e-6 * scale)
    # Elastic forces are internal: they sum to zero.
    np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-9 * scale)


@pytest.mark.parametrize("model", ["stvk", "corotated", "neohookean", "stable_neohookean"])
def test_tet_forces_are_minus_energy_gradient(model: str, box: defsim.Mesh) -> None:
    with defsim.World(gravity=(0, -9.81, 0)) as w:
        w.add_body(box, material=defsim.Material(model, youngs_modulus=1e5, poisson_ratio=0.3))
        _fd_check(w, perturbed(box.positions, 0.02))


def test_spring_forces_are_minus_energy_gradient() -> None:
    rng = np.random.default_rng(7)
    rest = rng.uniform(0, 1, size=(6, 3))
    springs = [[i, j] for i in range(6) for j in range(i + 1, 6)]
    k = rng.uniform(100, 1000, size=len(springs))
    with defsim.World() as w:
        w.add_body(rest, springs=springs, spring_stiffness=k,
                   material=defsim.Material("spring"))
        _fd_check(w, perturbed(rest, 0.05))


def test_forces_ignore_pins_gravity_and_damping(box: defsim.Mesh) -> None:
    x = perturbed(box.positions, 0.02)
    results = []
    for pinned, g, alpha in ((False, 0.0, 0.0), (True, -9.81, 2.0)):
        with defsim.World(gravity=(0, g, 0)) as w:
            b = w.add_body(box, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                         mass_damping=alpha))
            if pinned:
                w.pin(b, [0, 1, 2])
            w.set_state(x, np.ones_like(x))
            results.append(w.forces())
    assert np.array_equal(results[0], results[1])
