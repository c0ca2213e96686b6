# SPDX-License-Identifier: MIT
"""Worlds from Python against analytic results and independent computations."""
from __future__ import annotations

import math

import numpy as np
import pytest

import defsim
from conftest import perturbed


@pytest.mark.parametrize("backend,shift", [("symplectic_euler", 1), ("explicit_euler", -1)])
def test_free_fall_is_exact(backend: str, shift: int) -> None:
    # One free 1 kg vertex: v_n = n h g; y_n = h^2 g n (n + shift) / 2.
    g, h, n = (0.5, -9.81, 2.0), 1e-3, 250
    with defsim.World(backend, gravity=g) as w:
        w.add_body([[1.0, 2.0, 3.0]], material=defsim.Material("spring", vertex_mass=1.0))
        w.step(h, steps=n)
        expect_v = n * h * np.array(g)
        expect_x = np.array([1.0, 2.0, 3.0]) + h * h * np.array(g) * n * (n + shift) / 2
        np.testing.assert_allclose(w.velocities[0], expect_v, rtol=1e-12)
        np.testing.assert_allclose(w.positions[0], expect_x, rtol=1e-12)
        assert w.time == pytest.approx(n * h, rel=1e-12)


def test_spring_oscillator_period() -> None:
    # Two 0.1 kg vertices joined by a k = 40 N/m spring, stretched by a = 0.05 m: the stretch
    # is a cos(w t) with w = sqrt(2 k / m). After one period it is back to a (to O(h)).
    m, k, a, h = 0.1, 40.0, 0.05, 1e-5
    omega = math.sqrt(2 * k / m)
    with defsim.World("symplectic_euler", gravity=(0, 0, 0)) as w:
        w.add_body([[0, 0, 0], [1, 0, 0]], springs=[[0, 1]],
                   initial_positions=[[-a / 2, 0, 0], [1 + a / 2, 0, 0]],
                   material=defsim.Material("spring", stiffness=k, vertex_mass=m))
        quarter = int(round(0.5 * math.pi / omega / h))
        w.step(h, steps=quarter)
        stretch = lambda: w.positions[1, 0] - w.positions[0, 0] - 1.0   # noqa: E731
        assert abs(stretch()) < 1e-3 * a                        # a quarter period: zero
        e = w.energy()
        assert e.kinetic == pytest.approx(0.5 * k * a * a, rel=1e-3)   # all kinetic
        w.step(h, steps=3 * quarter)
        assert stretch() == pytest.approx(a, rel=1e-3)
        assert w.energy().elastic == pytest.approx(0.5 * k * a * a, rel=2e-3)
        # Momentum stays zero: the spring forces are internal.
        p = (w.masses[:, None] * w.velocities).sum(axis=0)
        np.testing.assert_allclose(p, 0.0, atol=1e-15)


def test_energy_against_independent_sums(box: defsim.Mesh) -> None:
    g = np.array([0.3, -9.81, 0.7])
    with defsim.World(gravity=g) as w:
        w.add_body(box, material=defsim.Material("corotated", youngs_modulus=1e5, density=800))
        x = perturbed(box.positions, 0.01)
        v = perturbed(np.zeros_like(x), 1.0, seed=5)
        w.set_state(x, v)
        m = w.masses
        e = w.energy()
        assert e.kinetic == pytest.approx(0.5 * np.sum(m[:, None] * v * v), rel=1e-13)
        assert e.gravitational == pytest.approx(-np.sum(m[:, None] * g * x), rel=1e-13)
        assert e.elastic > 0
        assert e.total == pytest.approx(e.kinetic + e.elastic + e.gravitational, rel=1e-14)
        w.set_state(box.positions, np.zeros_like(x))
        assert abs(w.energy().elastic) < 1e-9   # relative to rest


def test_pins_hold_and_release(box: defsim.Mesh) -> None:
    with defsim.World() as w:
        b = w.add_body(box, material=defsim.Material("corotated", youngs_modulus=1e5))
        bottom = box.positions[:, 1] == 0.0
        b.pin(bottom)
        w.step(1e-3, steps=50)
        x = w.positions
        assert np.array_equal(x[bottom], box.positions[bottom])
        assert np.all(w.velocities[bottom] == 0.0)
        assert np.all(x[~bottom, 1] < box.positions[~bottom, 1])   # the rest sags
        assert w.stats().passes & defsim.Pass.PINS
        b.unpin(np.flatnonzero(bottom))
        w.step(1e-3, steps=5)
        assert np.all(w.positions[bottom, 1] < 0.0)                # and now it falls
        assert not w.stats().passes & defsim.Pass.PINS
        b.pin(3)          # a single index
        b.pin([3, 3])     # pinning a pinned vertex is allowed
        w.step(1e-3)
        assert w.velocities[3].tolist() == [0.0, 0.0, 0.0]


def test_stats_and_passes(box: defsim.Mesh) -> None:
    with defsim.World(num_threads=1) as w:
        w.add_body(box, material=defsim.Material("stvk", mass_damping=0.1))
        w.add_body([[3, 0, 0], [4, 0, 0]], springs=[[0, 1]], material=defsim.Material("spring"))
        w.step(1e-3, steps=7)
        s = w.stats()
        assert s.steps == 7 and s.failed_steps == 0 and s.threads == 1
        assert s.force_evals >= 7 and s.time_step >= s.time_forces >= 0.0
        assert s.passes == (defsim.Pass.STVK | defsim.Pass.SPRINGS | defsim.Pass.GRAVITY |
                            defsim.Pass.MASS_DAMPING)
        w.reset_stats()
        s = w.stats()
        assert s.steps == 0 and s.force_evals == 0 and s.time_step == 0.0
        assert s.passes & defsim.Pass.STVK   # passes survive a reset
    with defsim.World(gravity=(0, 0, 0)) as w:
        w.add_body(box, material=defsim.Material("corotated"))
        w.step(1e-3)
        assert w.stats().passes == defsim.Pass.COROTATED   # unused passes are skipped


def test_options_reach_the_library(box: defsim.Mesh) -> None:
    with defsim.World("explicit_euler", gravity=[0, 0, -1.5], num_threads=1,
                      options={"core.auto_substep": False}) as w:
        assert w.backend == "explicit_euler" and w.gravity == (0.0, 0.0, -1.5)
        w.add_body([[0, 0, 0]], material=defsim.Material("spring", vertex_mass=2.0))
        w.step(0.5)
        assert w.velocities[0].tolist() == [0.0, 0.0, -0.75]
    with defsim.World() as w:
        assert w.backend == "symplectic_euler" and w.gravity == (0.0, -9.81, 0.0)
    # The backend settings of earlier versions' keywords are options by name now.
    with pytest.raises(TypeError):
        defsim.World(tolerance=1e-8)


def test_log_callback_receives_errors(box: defsim.Mesh) -> None:
    got = []
    with defsim.World(log=lambda level, msg: got.append((level, msg))) as w:
        with pytest.raises(defsim.InvalidArgumentError) as info:
            w.step(-1.0)
        assert got and got[-1][0] == 0 and got[-1][1] == info.value.message


def test_material_defaults_come_from_the_library() -> None:
    m = defsim.Material("corotated")
    assert (m.model, m.youngs_modulus, m.poisson_ratio, m.density) == (
        defsim.Model.COROTATED, 1e6, 0.3, 1000.0)
    assert m.vertex_mass == 0.0 and defsim.Material("spring").vertex_mass == 0.01
    assert defsim.Material(defsim.Model.STVK, youngs_modulus=5) == defsim.Material(
        "stvk", youngs_modulus=5.0)
    assert defsim.Material("Stable-Neo-Hookean").model is defsim.Model.STABLE_NEOHOOKEAN
    assert defsim.Material().model is defsim.Model.STABLE_NEOHOOKEAN
    assert eval(repr(m), {"Material": defsim.Material}) == m


def test_stvk_material_eval_analytic() -> None:
    # F = diag(s, 1, 1): E11 = (s^2 - 1)/2, psi = (mu + lambda/2) E11^2,
    # P11 = s (2 mu + lambda) E11, P22 = P33 = lambda E11; dP/dF by central differences.
    E, nu, s = 2e5, 0.25, 1.1
    mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    e11 = (s * s - 1) / 2
    mat = defsim.Material("stvk", youngs_modulus=E, poisson_ratio=nu)
    F = np.diag([s, 1.0, 1.0])
    r = defsim.material_eval(mat, F)
    assert r.psi == pytest.approx((mu + lam / 2) * e11 ** 2, rel=1e-12)
    np.testing.assert_allclose(np.diag(r.P), [s * (2 * mu + lam) * e11, lam * e11, lam * e11],
                               rtol=1e-12)
    rng = np.random.default_rng(11)
    G = np.eye(3) + 0.2 * rng.standard_normal((3, 3))
    d = 1e-6
    fd = np.empty((3, 3, 3, 3))
    for k in range(3):
        for l in range(3):
            Gp, Gm = G.copy(), G.copy()
            Gp[k, l] += d
            Gm[k, l] -= d
            fd[:, :, k, l] = (mat.eval(Gp).P - mat.eval(Gm).P) / (2 * d)
    r = mat.eval(G)
    np.testing.assert_allclose(r.dPdF, fd, atol=1e-6 * np.abs(r.dPdF).max())


def test_body_handles(world: defsim.World, box: defsim.Mesh) -> None:
    b = world.add_body(box)
    assert b.world is world and b.alive and b.vertex_count == box.vertex_count
    assert world.bodies[0] == b
    assert list(world) == [b] and "Body" in repr(b) and "symplectic_euler" in repr(world)
    with defsim.World() as other:
        c = other.add_body(box)
        assert b.id != c.id and b != c   # ids carry their world


def test_stable_step_and_auto_substep():
    """A mass m on a spring k to a pinned anchor: omega = sqrt(k/m), symplectic Euler's limit
    is 2/omega; with auto_substep a step 10x that limit runs in substeps and stays bounded."""
    import math

    m, k = 0.5, 200.0
    w0 = math.sqrt(k / m)
    for auto in (False, True):
        world = defsim.World("symplectic_euler", gravity=(0, 0, 0),
                             options={"core.auto_substep": auto})
        body = world.add_body([[0, 0, 0], [1, 0, 0]], springs=[[0, 1]],
                              material=defsim.Material("spring", stiffness=k),
                              vertex_mass=[m, m], initial_positions=[[0, 0, 0], [1.01, 0, 0]])
        body.pin([0])
        h, omega = world.stable_step()
        assert abs(omega - w0) < 1e-4 * w0
        assert abs(h - 2.0 / w0) < 1e-4 * h
        if auto:
            world.step(10 * h, steps=20)
            assert world.stats().substeps >= 200
            assert abs(world.positions[1, 0] - 1.0) < 0.02
        else:
            # Each step multiplies the amplitude by about (omega h)^2 = 400: non-finite soon.
            with pytest.raises(defsim.UnstableError):
                world.step(10 * h, steps=200)


@pytest.mark.parametrize("quadratic", [False, True])
def test_volume_averaging(box: defsim.Mesh, quadratic: bool) -> None:
    """The averaged-nodal-volume tet (linear tets) and the mean-dilatation element (quadratic
    tets) through the binding: refused for StVK, the standard element's energy under a
    homogeneous stretch, softer than the locking standard element under a non-homogeneous one
    at nu = 0.499."""
    if quadratic:
        box = defsim.mesh_box((0, 0, 0), (0.4, 0.2, 0.2), cells=(2, 1, 1), quadratic=True)
    with defsim.World() as w:
        with pytest.raises(defsim.InvalidMaterialError, match="volume_averaging"):
            w.add_body(box, material=defsim.Material("stvk"), volume_averaging=True)
    mat = defsim.Material("neohookean", youngs_modulus=1e6, poisson_ratio=0.499)
    F = np.array([[1.02, 0.01, 0.0], [0.0, 0.99, 0.02], [0.0, 0.0, 1.01]])
    bend = box.positions.copy()
    bend[:, 1] *= 1.0 + 0.3 * bend[:, 0] ** 2     # J differs from element to element
    energies = {}
    for avg in (False, True):
        with defsim.World() as w:
            w.add_body(box, material=mat, volume_averaging=avg)
            w.set_state(box.positions @ F.T, np.zeros_like(box.positions))
            homogeneous = w.energy().elastic
            w.set_state(bend, np.zeros_like(bend))
            energies[avg] = (homogeneous, w.energy().elastic)
    assert energies[True][0] == pytest.approx(energies[False][0], rel=1e-12)
    assert 0 < energies[True][1] < energies[False][1]
