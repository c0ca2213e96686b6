# SPDX-License-Identifier: MIT
"""world.record() / tape.backward(): gradients of a loss of the recorded states against central
finite differences of whole runs (Young's modulus, density, mass damping, the initial state), on
symplectic Euler, velocity Verlet, newton_cholmod and bdf2 (and the driven pins' targets); bad
input raises and leaves the world as it was."""
from __future__ import annotations

import numpy as np
import pytest

import defsim

STEPS = 10


def _world(backend: str, E: float = 2e5, rho: float = 800.0, alpha: float = 0.5,
           x0: np.ndarray = None, v0: np.ndarray = None) -> defsim.World:
    opts = ({f"{backend}.tolerance": 1e-13} if backend in ("newton_cholmod", "bdf2") else None)
    w = defsim.World(backend, gravity=(0, -9.81, 0), options=opts)
    mesh = defsim.mesh_box((0, 0, 0), (2, 1, 1), cells=(2, 1, 1))
    b = w.add_body(mesh, material=defsim.Material("corotated", youngs_modulus=E,
                                                  poisson_ratio=0.3, density=rho,
                                                  mass_damping=alpha))
    w.pin(b, np.flatnonzero(mesh.positions[:, 0] == 0.0))
    x = w.positions.copy() if x0 is None else x0
    r = mesh.positions
    v = 0.3 * np.stack([np.zeros(len(r)), r[:, 0], -r[:, 0]], axis=1) if v0 is None else v0.copy()
    v[mesh.positions[:, 0] == 0.0] = 0.0
    w.set_state(x, v)
    return w


def _loss(w: defsim.World, h: float, c: np.ndarray) -> float:
    for _ in range(STEPS):
        w.step(h)
    return float(np.sum(c * w.positions))


@pytest.mark.parametrize("backend,h", [("symplectic_euler", 2e-3), ("velocity_verlet", 2e-3),
                                       ("newton_cholmod", 1e-2), ("bdf2", 1e-2)])
def test_gradients_match_central_differences(backend: str, h: float) -> None:
    w = _world(backend)
    x0, v0 = w.positions.copy(), w.velocities.copy()
    c = np.random.default_rng(1).standard_normal(x0.shape)
    tape = w.record()
    w.step(h, STEPS)
    dL_dx = np.zeros((STEPS + 1,) + x0.shape)
    dL_dx[-1] = c
    g = tape.backward(dL_dx=dL_dx)
    assert tape.stats()["steps"] == STEPS
    assert g["external_forces"].shape == (STEPS,) + x0.shape
    assert g["initial_positions"].shape == x0.shape and g["youngs_modulus"].shape == (1,)
    d = np.random.default_rng(2).standard_normal(x0.shape)
    d[x0[:, 0] == 0.0] = 0.0
    cases = {
        "youngs_modulus": (lambda e: _world(backend, E=2e5 * (1 + e)), 2e5, 1e-6),
        "density": (lambda e: _world(backend, rho=800 * (1 + e)), 800.0, 1e-6),
        "mass_damping": (lambda e: _world(backend, alpha=0.5 + e), 1.0, 1e-4),
        "initial_positions": (lambda e: _world(backend, x0=x0 + e * d), 1.0, 1e-6),
        "initial_velocities": (lambda e: _world(backend, v0=v0 + e * d), 1.0, 1e-6),
    }
    # a constant held force F: dL/dF is the sum of the steps' gradients
    F = np.random.default_rng(3).standard_normal(x0.shape)

    def with_force(e: float) -> defsim.World:
        w = _world(backend)
        w.set_external_forces(e * F)
        return w
    # dL/dF is small against L (its round-off): a wide step, L being nearly linear in F
    fd = (_loss(with_force(1e-2), h, c) - _loss(with_force(-1e-2), h, c)) / 2e-2
    an = float(np.sum(g["external_forces"].sum(axis=0) * F))
    assert abs(an - fd) <= 1e-5 * abs(fd), ("external_forces", an, fd)
    for name, (make, scale, eps) in cases.items():
        fd = (_loss(make(eps), h, c) - _loss(make(-eps), h, c)) / (2 * eps)
        an = float(np.sum(g[name] * d)) if name.startswith("initial") else float(g[name][0]) * scale
        assert abs(an - fd) <= 1e-5 * abs(fd), (name, an, fd)


def test_bad_input_leaves_the_world() -> None:
    w = _world("symplectic_euler")
    cb = _world("symplectic_euler")
    cb.set_force_callback(lambda x, v, t: np.zeros_like(x))
    with pytest.raises(defsim.UnsupportedError, match="callback"):
        cb.record()
    tape = w.record()
    with pytest.raises(defsim.InvalidArgumentError):
        w.record()
    w.step(1e-3, 3)
    x = w.positions.copy()
    with pytest.raises(defsim.InvalidArgumentError):
        tape.backward(dL_dx=np.zeros((3, w.vertex_count, 3)))
    bad = np.zeros((4, w.vertex_count, 3))
    bad[1, 2, 0] = np.nan
    with pytest.raises(defsim.InvalidArgumentError):
        tape.backward(dL_dx=bad)
    with pytest.raises(defsim.InvalidArgumentError):
        tape.backward(dL_dx=np.zeros((4, w.vertex_count, 3)), params=["youngs"])
    assert np.array_equal(w.positions, x) and w.time == pytest.approx(3e-3)
    tape.close()
    with pytest.raises(defsim.InvalidArgumentError):
        tape.backward()


@pytest.mark.parametrize("backend,h", [("symplectic_euler", 2e-3), ("velocity_verlet", 2e-3),
                                       ("newton_cholmod", 1e-2), ("bdf2", 1e-2)])
def test_pin_targets_match_central_differences(backend: str, h: float) -> None:
    """The clamped face driven up over the steps: dL/d(pin targets) against central
    differences along a random direction of all the steps' targets."""
    rng = np.random.default_rng(4)
    w0 = _world(backend)
    face = np.flatnonzero(w0.positions[:, 0] == 0.0)
    base = w0.positions[face].copy()
    c = rng.standard_normal(w0.positions.shape)
    D = rng.standard_normal((STEPS, len(face), 3))

    def run(e: float, tape: bool = False):
        w = _world(backend)
        t = w.record() if tape else None
        for s in range(STEPS):
            w.bodies[0].set_pin_targets(face, base + [0.0, 0.04 * (s + 1) * h, 0.0] + e * D[s])
            w.step(h)
        L = float(np.sum(c * w.positions))
        if not tape:
            return L
        dL_dx = np.zeros((STEPS + 1,) + w.positions.shape)
        dL_dx[-1] = c
        return t.backward(dL_dx=dL_dx, params=["pin_targets"])["pin_targets"]

    g = run(0.0, tape=True)
    assert g.shape == (STEPS,) + w0.positions.shape
    others = np.setdiff1d(np.arange(w0.vertex_count), face)
    assert not g[:, others].any()
    an = float(np.sum(g[:, face] * D))
    fd = (run(1e-6) - run(-1e-6)) / 2e-6
    assert abs(an - fd) <= 1e-5 * abs(fd), (an, fd)


def _block_on_plane(mu: float) -> defsim.World:
    opts = {"newton_cholmod.tolerance": 1e-13, "newton_cholmod.contact_tolerance": 0.0}
    w = defsim.World("newton_cholmod", gravity=(3.0, -9.81, 0), options=opts)
    mesh = defsim.mesh_box((0, 1e-4, 0), (0.1, 0.1001, 0.1), cells=(1, 1, 1))
    w.add_body(mesh, material=defsim.Material("stable_neohookean", youngs_modulus=1e5,
                                              poisson_ratio=0.3, density=1000.0))
    w.add_collider("plane", friction=mu)
    return w


def test_collider_friction_gradient() -> None:
    """A block sliding on a plane (gravity tilted along x): dL/dmu of the travel along x after
    10 steps against central differences (docs/gradients.md, Contact)."""
    h = 1e-2
    w = _block_on_plane(0.2)
    n = w.vertex_count
    tape = w.record()
    w.step(h, STEPS)
    dL_dx = np.zeros((STEPS + 1, n, 3))
    dL_dx[-1, :, 0] = 1.0 / n
    g = tape.backward(dL_dx=dL_dx)
    assert g["collider_friction"].shape == (1,)

    def travel(mu: float) -> float:
        b = _block_on_plane(mu)
        b.step(h, STEPS)
        return float(b.positions[:, 0].mean())
    fd = (travel(0.2 + 1e-6) - travel(0.2 - 1e-6)) / 2e-6
    an = float(g["collider_friction"][0])
    assert fd < 0.0 and abs(an - fd) <= 1e-5 * abs(fd), (an, fd)


def test_collider_poses_gradient() -> None:
    """The block on a plane that slides along x under it (1 mm per step) and lifts 10 um per
    step: dL/d of the plane's x position at state 5 and of its rotation about z there (the
    pose moved to (I + [dtheta]) R), against central differences with steps e and 2 e,
    extrapolated (docs/gradients.md, "Collider poses")."""
    h = 1e-2

    def run(w: defsim.World, ds: int = -1, dp: float = 0.0, dth: float = 0.0) -> None:
        c = w.colliders[0]
        for s in range(STEPS):
            p = np.array([1e-3 * (s + 1), 1e-5 * (s + 1), 0.0])
            q = np.array([1.0, 0.0, 0.0, 0.0])
            if s + 1 == ds:
                p[0] += dp
                q = np.array([np.cos(dth / 2), 0.0, 0.0, np.sin(dth / 2)])
            c.set_pose(p, q)
            w.step(h)

    w = _block_on_plane(0.4)
    n = w.vertex_count
    tape = w.record()
    run(w)
    dL_dx = np.zeros((STEPS + 1, n, 3))
    dL_dx[-1, :, 0] = 1.0 / n
    dL_dx[-1, :, 1] = 1.0 / n
    g = tape.backward(dL_dx=dL_dx, params=["collider_poses"])["collider_poses"]
    assert g.shape == (STEPS + 1, 1, 6)

    def loss(dp: float, dth: float) -> float:
        b = _block_on_plane(0.4)
        run(b, 5, dp, dth)
        return float(b.positions[:, 0].mean() + b.positions[:, 1].mean())
    for k, e in ((0, 1e-7), (5, 1e-6)):
        def d(m: float) -> float:   # central differences with step m e
            dp, dth = (m * e, 0.0) if k == 0 else (0.0, m * e)
            return (loss(dp, dth) - loss(-dp, -dth)) / (2 * m * e)
        fd = (4.0 * d(1.0) - d(2.0)) / 3.0   # Richardson
        an = float(g[5, 0, k])
        assert abs(fd) > 1e-3 and abs(an - fd) <= 1e-5 * abs(fd), (k, an, fd)
