# SPDX-License-Identifier: MIT
"""Shells from Python (docs/shells.md): the Shell fields reach the library (a sheet's uniaxial
stretch gives the analytic StVK force, a pre-bent strip is at rest, forces are minus the
energy's gradient), and bad values raise."""
from __future__ import annotations

import numpy as np
import pytest

import defsim


def _sheet(shell: defsim.Shell) -> tuple:
    mesh = defsim.mesh_cloth((0, 0, 0), (0.4, 0, 0), (0, 0.3, 0), 8, 6)
    w = defsim.World(backend="symplectic_euler", gravity=(0, 0, 0))
    w.add_body(mesh.positions, triangles=mesh.triangles, shell=shell)
    return w, mesh


def test_biaxial_stretch_force():
    E, nu, t = 2e6, 0.3, 1e-3
    w, mesh = _sheet(defsim.Shell(membrane=defsim.Membrane.STVK, youngs_modulus=E,
                                  poisson_ratio=nu, thickness=t, bending_rigidity=0.0))
    l1, l2 = 1.2, 1.1
    x = mesh.positions * np.array([l1, l2, 1.0])
    f = w.forces(x)
    mu, lam = E * t / (2 * (1 + nu)), E * t * nu / (1 - nu * nu)
    E1, E2 = 0.5 * (l1 * l1 - 1), 0.5 * (l2 * l2 - 1)
    P11 = l1 * ((lam + 2 * mu) * E1 + lam * E2)
    right = np.isclose(mesh.positions[:, 0], 0.4)
    assert f[right, 0].sum() == pytest.approx(-P11 * 0.3, rel=1e-9)


def test_prebent_rest_and_gradient():
    mesh = defsim.mesh_cloth((0, 0, 0), (1, 0, 0), (0, 0, 0.05), 12, 2)
    p = mesh.positions.copy()
    s = p[:, 0] * np.pi / 2
    p[:, 0], p[:, 1] = 0.2 * np.sin(s), 0.2 * (1 - np.cos(s))
    w = defsim.World(backend="symplectic_euler", gravity=(0, 0, 0))
    w.add_body(p, triangles=mesh.triangles,
               shell=defsim.Shell(membrane=defsim.Membrane.NEOHOOKEAN, youngs_modulus=1e5,
                                  bending_rigidity=1e-3, bending_rigidity_weft=5e-4))
    assert np.abs(w.forces(p)).max() < 1e-12
    rng = np.random.default_rng(1)
    x = p + 0.002 * rng.standard_normal(p.shape)
    f = w.forces(x).reshape(-1)
    fd = np.empty(x.size)
    for i in range(x.size):
        xp, xm = x.copy().reshape(-1), x.copy().reshape(-1)
        xp[i] += 1e-7
        xm[i] -= 1e-7
        w.set_state(xp.reshape(-1, 3))
        ep = w.energy().elastic
        w.set_state(xm.reshape(-1, 3))
        fd[i] = -(ep - w.energy().elastic) / 2e-7
    np.testing.assert_allclose(f, fd, rtol=0, atol=1e-5 * np.abs(f).max())


def test_bad_values_raise():
    with pytest.raises(defsim.InvalidMaterialError):
        _sheet(defsim.Shell(membrane=defsim.Membrane.STVK, thickness=0.0))
    with pytest.raises(defsim.InvalidArgumentError):
        _sheet(defsim.Shell(membrane=7))
    with pytest.raises(defsim.InvalidArgumentError):
        _sheet(defsim.Shell(membrane=defsim.Membrane.STVK, warp_direction=(1, 0)))


def _largest_stretch(rest: np.ndarray, x: np.ndarray, tris: np.ndarray) -> float:
    """The largest principal stretch of any triangle of a flat rest sheet (in the xy plane)."""
    r0, r1, r2 = rest[tris[:, 0]], rest[tris[:, 1]], rest[tris[:, 2]]
    dm = np.stack([r1[:, :2] - r0[:, :2], r2[:, :2] - r0[:, :2]], axis=2)   # (t, 2, 2)
    ds = np.stack([x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]]], axis=2)
    f = ds @ np.linalg.inv(dm)                                             # (t, 3, 2)
    return float(np.linalg.svd(f, compute_uv=False).max())


def test_strain_limit_holds_the_cap():
    """A sheet pinned along x = 0 and pulled along x by a load that stretches it about 30 %
    stays below a 10 % cap (stretches from the positions), and is in the band below it."""
    mesh = defsim.mesh_cloth((0, 0, 0), (0.4, 0, 0), (0, 0.2, 0), 8, 4)
    rest, tris = mesh.positions, np.asarray(mesh.triangles).reshape(-1, 3)
    stretch = []
    for cap in (0.0, 0.1):
        w = defsim.World(backend="newton_cholmod", gravity=(0, 0, 0))
        body = w.add_body(rest, triangles=mesh.triangles,
                          shell=defsim.Shell(membrane=defsim.Membrane.STVK, youngs_modulus=1e6,
                                             thickness=1e-3, bending_rigidity=0.0,
                                             strain_limit=cap))
        w.pin(body, np.flatnonzero(np.isclose(rest[:, 0], 0.0)))
        f = np.zeros_like(rest)
        right = np.isclose(rest[:, 0], 0.4)
        f[right, 0] = 0.2 * 1000 * 1.3 * (1.3 ** 2 - 1) / 2 / right.sum()
        w.set_external_forces(f)
        worst = 0.0
        for _ in range(10):
            w.step(0.5)
            worst = max(worst, _largest_stretch(rest, w.positions, tris))
        stretch.append(worst)
    assert stretch[0] > 1.3
    assert 1.09 < stretch[1] < 1.1


def test_strain_limit_bad_values_raise():
    with pytest.raises(defsim.InvalidMaterialError):
        _sheet(defsim.Shell(membrane=defsim.Membrane.STVK, strain_limit=-0.1))
    with pytest.raises(defsim.BackendUnavailableError):   # symplectic_euler: no filtered search
        _sheet(defsim.Shell(membrane=defsim.Membrane.STVK, strain_limit=0.1))
def test_fabric_by_name():
    """The table of measured fabrics (docs/shells.md): names, the denim's numbers, the same
    body as the explicit Shell, an unknown name refused."""
    names = defsim.fabrics()
    assert names[0] == "denim" and "cotton_polyester" in names and len(names) == 6
    s = defsim.Shell.from_fabric("denim", warp_direction=(0, 1, 0))
    assert s.membrane == defsim.Membrane.ORTHOTROPIC_STVK
    assert (s.areal_density, s.warp_modulus, s.weft_modulus, s.shear_modulus, s.warp_poisson,
            s.bending_rigidity, s.bending_rigidity_weft) == (
        0.324, 410.5, 2026.8, 53.387, 0.01009, 2.424e-5, 1.605e-5)
    explicit = defsim.Shell(membrane=defsim.Membrane.ORTHOTROPIC_STVK, areal_density=0.324,
                            warp_modulus=410.5, weft_modulus=2026.8, shear_modulus=53.387,
                            warp_poisson=0.01009, bending_rigidity=2.424e-5,
                            bending_rigidity_weft=1.605e-5, warp_direction=(0, 1, 0))
    w1, mesh = _sheet(s)
    w2, _ = _sheet(explicit)
    x = mesh.positions * np.array([1.03, 1.0, 0.98])
    x[:, 2] += 0.05 * mesh.positions[:, 0] ** 2
    np.testing.assert_array_equal(w1.forces(x), w2.forces(x))
    assert np.abs(w1.forces(x)).max() > 1e-3
    with pytest.raises(defsim.InvalidMaterialError, match="unknown fabric"):
        defsim.Shell.from_fabric("velvet")
    with pytest.raises(defsim.InvalidArgumentError):
        defsim.Shell.from_fabric(3)
