# SPDX-License-Identifier: MIT
"""Coupling with the host from Python: external forces and force callbacks (n h F / m), driven
pins landing on their targets, pin forces of a settled cantilever against its weight, an
attachment holding a hanging body, exceptions in callbacks, element stress against
material_eval."""
from __future__ import annotations

from typing import List

import numpy as np
import pytest

import defsim
from conftest import world_or_skip

BACKENDS = ["explicit_euler", "symplectic_euler", "newton_cholmod", "sundials_ida",
            "sundials_kinsol"]


def _world(backend: str, **kw) -> defsim.World:
    return world_or_skip(backend, **kw)


def _beam(w: defsim.World, cells=(6, 2, 2), damping=0.0) -> defsim.Body:
    mesh = defsim.mesh_box((0, 0, 0), (1.2, 0.2, 0.2), cells=cells)
    mat = defsim.Material("corotated", youngs_modulus=2e5, poisson_ratio=0.3, density=500,
                          mass_damping=damping)
    return w.add_body(mesh, material=mat)


def test_constant_external_force_gives_n_h_f_over_m() -> None:
    """Free body, no gravity, F_i = m_i a: symplectic Euler gives v_i = n h F_i / m_i."""
    with defsim.World("symplectic_euler", gravity=(0, 0, 0)) as w:
        b = _beam(w)
        m = w.masses
        a = np.array([0.3, -1.2, 2.0])
        F = m[:, None] * a
        w.set_external_forces(F)
        h, n = 1e-3, 50
        w.step(h, steps=n)
        np.testing.assert_allclose(w.velocities, n * h * F / m[:, None], rtol=1e-9, atol=1e-12)
        # Momentum grows as t sum F.
        np.testing.assert_allclose((m[:, None] * w.velocities).sum(axis=0), n * h * F.sum(axis=0),
                                   rtol=1e-12)
        # Cleared: the velocity stays.
        w.set_external_forces(None)
        v = w.velocities
        w.step(h)
        np.testing.assert_allclose(w.velocities, v, rtol=1e-9, atol=1e-12)
        assert b.alive


def test_callback_force_gives_n_h_f_over_m_and_sees_time() -> None:
    seen: List[float] = []
    with defsim.World("symplectic_euler", gravity=(0, 0, 0)) as w:
        _beam(w)
        m = w.masses
        F = m[:, None] * np.array([0.0, 0.0, 1.5])

        def force(x: np.ndarray, v: np.ndarray, t: float) -> np.ndarray:
            assert x.shape == v.shape == F.shape and not x.flags.writeable
            seen.append(t)
            return F

        w.set_force_callback(force)
        h, n = 2e-3, 20
        w.step(h, steps=n)
        np.testing.assert_allclose(w.velocities, n * h * F / m[:, None], rtol=1e-9, atol=1e-12)
        # One evaluation per step at the step's start time at least.
        for k in range(n):
            assert any(abs(t - k * h) < 1e-12 for t in seen)


def test_bad_external_forces_leave_the_world_unchanged(world: defsim.World) -> None:
    _beam(world)
    n = world.vertex_count
    F = np.zeros((n, 3))
    F[3, 1] = np.nan
    with pytest.raises(defsim.InvalidArgumentError):
        world.set_external_forces(F)
    with pytest.raises(defsim.InvalidArgumentError):
        world.set_external_forces(np.zeros((n - 1, 3)))
    x = world.positions
    world.step(1e-4)
    # Gravity only: no external force was held.
    np.testing.assert_allclose(world.velocities[:, 1], -9.81e-4, rtol=1e-9)
    assert np.all(np.isfinite(world.positions - x))


def test_exception_in_callback_is_chained_and_state_unchanged() -> None:
    calls = [0]

    class Boom(RuntimeError):
        pass

    def force(x: np.ndarray, v: np.ndarray, t: float) -> np.ndarray:
        calls[0] += 1
        if calls[0] >= 4:
            raise Boom("host failed")
        return np.zeros_like(x)

    with defsim.World("symplectic_euler") as w:
        _beam(w)
        w.set_force_callback(force)
        w.step(1e-4, steps=3)
        x, v, t = w.positions, w.velocities, w.time
        steps = w.stats().steps
        with pytest.raises(defsim.StepError) as info:
            w.step(1e-4)
        assert isinstance(info.value.__cause__, Boom)
        assert info.value.status == defsim.Status.CALLBACK
        assert isinstance(info.value, defsim.CallbackError)
        np.testing.assert_array_equal(w.positions, x)
        np.testing.assert_array_equal(w.velocities, v)
        assert w.time == t and w.stats().steps == steps
        # Clearing the callback makes the world usable again.
        w.set_force_callback(None)
        w.step(1e-4)
        assert w.time > t


def test_callback_with_wrong_shape_fails_the_step() -> None:
    with defsim.World("symplectic_euler") as w:
        _beam(w)
        w.set_force_callback(lambda x, v, t: np.zeros(5))
        x = w.positions
        with pytest.raises(defsim.StepError) as info:
            w.step(1e-4)
        assert isinstance(info.value.__cause__, defsim.InvalidArgumentError)
        np.testing.assert_array_equal(w.positions, x)


@pytest.mark.parametrize("backend", BACKENDS)
def test_driven_vertex_lands_on_its_target(backend: str) -> None:
    with _world(backend) as w:
        b = _beam(w, damping=1.0)
        clamp = np.flatnonzero(b.positions[:, 0] == 0.0)
        rest = b.positions[clamp]
        h = 1e-3 if backend in ("explicit_euler", "symplectic_euler") else 5e-3
        for k in range(1, 6):
            # The clamped end goes round a circle of radius 5 cm in the y-z plane.
            ang = 2 * np.pi * k / 20
            target = rest + np.array([0.0, 0.05 * np.sin(ang), 0.05 * (1 - np.cos(ang))])
            b.set_pin_targets(clamp, target)
            before = b.positions[clamp]
            w.step(h)
            np.testing.assert_allclose(b.positions[clamp], target, rtol=0, atol=1e-12)
            np.testing.assert_allclose(b.velocities[clamp], (target - before) / h, rtol=1e-9,
                                       atol=1e-9)


def test_pin_targets_reject_bad_input(world: defsim.World) -> None:
    b = _beam(world)
    x = world.positions
    with pytest.raises(defsim.InvalidArgumentError):
        b.set_pin_targets([0], [[np.nan, 0, 0]])
    with pytest.raises(defsim.InvalidArgumentError):
        b.set_pin_targets([b.vertex_count], [[0, 0, 0]])
    b.remove()
    with pytest.raises(defsim.StaleIdError):
        b.set_pin_targets([0], [[0, 0, 0]])
    assert world.vertex_count == 0 and x.shape[0] > 0


def _settle(w: defsim.World, h: float, steps: int) -> None:
    w.step(h, steps=steps)
    assert np.abs(w.velocities).max() < 1e-9


def test_pin_forces_of_a_settled_cantilever_sum_to_its_weight() -> None:
    g = np.array([0.0, -9.81, 0.0])
    with _world("newton_cholmod", gravity=tuple(g)) as w:
        # About critical damping of the first bending mode (omega_1 = 2.8 rad/s).
        b = _beam(w, damping=6.0)
        clamp = b.positions[:, 0] == 0.0
        w.pin(b, clamp)
        _settle(w, 0.02, 400)
        R = w.pin_forces()
        weight = w.masses.sum() * g
        assert np.all(R[~clamp] == 0.0)
        # The support holds the beam up: the reactions sum to minus its weight.
        np.testing.assert_allclose(R.sum(axis=0), -weight, rtol=0,
                                   atol=1e-6 * np.linalg.norm(weight))
        # And they hold a moment: the clamp's top pulls, its bottom pushes, along x.
        assert np.ptp(R[clamp][:, 0]) > 0.1 * np.linalg.norm(weight)


def test_attachment_holds_a_hanging_body_with_its_weight() -> None:
    g = np.array([0.0, -9.81, 0.0])
    with _world("newton_cholmod", gravity=tuple(g)) as w:
        b = _beam(w, cells=(2, 1, 1), damping=6.0)
        top = np.flatnonzero(b.positions[:, 1] == 0.2)
        atts = [w.add_attachment(b, int(v), stiffness=5e4) for v in top]
        _settle(w, 0.02, 400)
        total = sum(a.force for a in atts)
        weight = w.masses.sum() * g
        np.testing.assert_allclose(total, -weight, rtol=0, atol=1e-6 * np.linalg.norm(weight))
        # The springs stretched by weight / (k * count) on average.
        sag = (b.positions[top, 1] - 0.2).mean()
        np.testing.assert_allclose(sag, weight[1] / (5e4 * len(top)), rtol=1e-6)
        # A moved target: the spring pulls with -k (x - p) towards it; removal makes the handle
        # stale.
        p = b.positions[top[0]] + np.array([0.0, 0.1, 0.0])
        atts[0].set_target(p)
        np.testing.assert_allclose(atts[0].force, -5e4 * (b.positions[top[0]] - p), rtol=1e-12)
        atts[0].remove()
        with pytest.raises(defsim.StaleIdError):
            atts[0].force
        with pytest.raises(defsim.StaleIdError):
            atts[0].set_target((0, 0, 0))


def test_attachment_between_bodies_by_barycentric_weights() -> None:
    with defsim.World("symplectic_euler", gravity=(0, 0, 0)) as w:
        a = _beam(w, cells=(1, 1, 1))
        b = _beam(w, cells=(1, 1, 1))
        att = w.add_attachment(a, 0, target_body=b, target_vertices=[1, 2],
                               target_weights=[0.25, 0.75], stiffness=100.0)
        xb = b.positions
        p = 0.25 * xb[1] + 0.75 * xb[2]
        np.testing.assert_allclose(att.force, -100.0 * (a.positions[0] - p), rtol=1e-12)
        with pytest.raises(defsim.InvalidArgumentError):
            w.add_attachment(a, 0, target_body=b, target_vertices=[1, 2],
                             target_weights=[0.5, 0.6])


def _tet_world(model: str):
    w = defsim.World("symplectic_euler", gravity=(0, 0, 0))
    X = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    mat = defsim.Material(model, youngs_modulus=1e5, poisson_ratio=0.3, density=1000)
    b = w.add_body(X, tets=[[0, 1, 2, 3]], material=mat)
    return w, b, X, mat


@pytest.mark.parametrize("model", ["stvk", "corotated", "neohookean", "stable_neohookean"])
def test_element_stress_of_a_uniformly_deformed_tet(model: str) -> None:
    w, b, X, mat = _tet_world(model)
    with w:
        rest = b.element_stress()
        assert np.all(rest.cauchy == 0.0) and np.all(rest.von_mises == 0.0)
        np.testing.assert_allclose(rest.energy_density, 0.0, atol=1e-9)
        F = np.array([[1.2, 0.1, 0.0], [0.05, 0.9, 0.02], [0.0, -0.03, 1.1]])
        w.positions = X @ F.T    # x = F X: the tet deforms uniformly with gradient F
        s = b.element_stress()
        ev = defsim.material_eval(mat, F, tangent=False)
        J = np.linalg.det(F)
        sigma = ev.P @ F.T / J
        np.testing.assert_allclose(s.cauchy[0], sigma, rtol=1e-10, atol=1e-9 * np.abs(sigma).max())
        dev = sigma - np.trace(sigma) / 3 * np.eye(3)
        np.testing.assert_allclose(s.von_mises[0], np.sqrt(1.5 * np.sum(dev * dev)), rtol=1e-10)
        psi0 = defsim.material_eval(mat, np.eye(3), stress=False, tangent=False).psi
        np.testing.assert_allclose(s.energy_density[0], ev.psi - psi0, rtol=1e-10)
        # A uniaxial stretch of StVK has the textbook stress: sigma_xx = P_xx F_xx / J.
        assert s.cauchy.shape == (1, 3, 3) and s.von_mises.shape == (1,)


def test_element_stress_of_a_spring_body_is_empty(world: defsim.World) -> None:
    rope = defsim.mesh_rope((0, 0, 0), (1, 0, 0), 4)
    b = world.add_body(rope, material=defsim.Material("spring", stiffness=100, vertex_mass=0.1))
    s = b.element_stress()
    assert s.cauchy.shape == (0, 3, 3) and s.von_mises.shape == (0,)


def test_callback_jacobian_matches_attachment_springs() -> None:
    """A callback force -k (x - x0) with its Jacobian -k I, stepped implicitly, gives what
    zero-rest-length attachments of stiffness k to x0 give (same force, same Hessian), in as
    many Newton iterations; without the Jacobian the force is held over each step and the
    result differs."""
    k, h = 2e3, 0.01
    results = []
    for mode in ("attachments", "jacobian", "held"):
        with _world("newton_cholmod", gravity=(0, -9.81, 0),
                    options={"newton_cholmod.tolerance": 1e-12}) as w:
            b = _beam(w, cells=(3, 1, 1))
            x0 = w.positions
            if mode == "attachments":
                for v in range(b.vertex_count):
                    w.add_attachment(b, v, stiffness=k)
            else:
                n = w.vertex_count
                jac = np.broadcast_to(-k * np.eye(3), (n, 3, 3)).copy()
                w.set_force_callback(lambda x, v, t: -k * (x - x0),
                                     (lambda x, v, t: jac) if mode == "jacobian" else None)
            w.step(h, steps=10)
            results.append((w.positions, w.stat("newton_cholmod.newton_iterations")))
    (xa, na), (xj, nj), (xh, _) = results
    scale = np.abs(xa - xa[0]).max()
    np.testing.assert_allclose(xj, xa, rtol=0, atol=1e-9 * scale)
    assert nj == na
    assert np.abs(xh - xa).max() > 1e-6 * scale
