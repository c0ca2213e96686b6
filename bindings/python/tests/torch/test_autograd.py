# SPDX-License-Identifier: MIT
"""defsim.autograd.simulate (torch.autograd over a run): a loss of the trajectory built from
torch operations (nonlinear in both positions and velocities) backpropagates into Young's
modulus, mass damping, the initial state, the held forces and the driven pins' targets, against
central differences of whole runs; the gradients keep their inputs' dtype; a second backward
with retain_graph gives the same; and the Tape's own backward gives the same numbers."""
from __future__ import annotations

import numpy as np
import pytest
import torch

import defsim
import defsim.autograd as dga

STEPS = 8
H = 1e-2
MESH = defsim.mesh_box((0, 0, 0), (2, 1, 1), cells=(2, 1, 1))
FACE = np.flatnonzero(MESH.positions[:, 0] == 0.0)


def make_world(p: dict) -> defsim.World:
    w = defsim.World("newton_cholmod", gravity=(0, -9.81, 0), num_threads=1,
                     options={"newton_cholmod.tolerance": 1e-13})
    w.add_body(MESH, material=defsim.Material(
        "stable_neohookean", youngs_modulus=float(p.get("youngs_modulus", [2e5])[0]),
        poisson_ratio=0.3, density=800.0, mass_damping=float(p.get("mass_damping", [0.5])[0])))
    return w


def inputs() -> dict:
    n = len(MESH.positions)
    rng = np.random.default_rng(3)
    v0 = 0.3 * np.stack([np.zeros(n), MESH.positions[:, 0], -MESH.positions[:, 0]], axis=1)
    targets = MESH.positions[FACE][None] + np.arange(1, STEPS + 1)[:, None, None] * \
        np.array([0.0, 0.02, 0.0])
    t = lambda a: torch.tensor(a, dtype=torch.float64, requires_grad=True)
    return {"E": t([2e5]), "alpha": t([0.5]), "x0": t(MESH.positions.copy()), "v0": t(v0),
            "f": t(0.1 * rng.standard_normal((STEPS, n, 3))), "p": t(targets)}


def loss_of(a: dict, dtype=torch.float64) -> torch.Tensor:
    X, V = dga.simulate(make_world, H, STEPS,
                        params={"youngs_modulus": a["E"], "mass_damping": a["alpha"]},
                        x0=a["x0"], v0=a["v0"], external_forces=a["f"],
                        pin_targets=(0, FACE, a["p"]))
    c = torch.from_numpy(np.random.default_rng(1).standard_normal(X.shape[1:]))
    return (c * X[-1]).sum() + 0.5 * (V[STEPS // 2] ** 2).sum() + torch.sin(X[:, :, 1]).sum()


def test_gradients_match_central_differences() -> None:
    a = inputs()
    L = loss_of(a)
    L.backward()
    assert a["p"].grad.shape == a["p"].shape and a["f"].grad.shape == a["f"].shape
    rng = np.random.default_rng(7)
    for name, eps in (("E", 1e-6), ("alpha", 1e-5), ("x0", 1e-6), ("v0", 1e-6), ("f", 1e-4),
                      ("p", 1e-6)):
        base = a[name].detach()
        d = torch.from_numpy(rng.standard_normal(base.shape))
        if name == "x0":
            d[FACE] = 0.0   # the face is driven: its start moves with its targets' velocity
        scale = base.abs().max().item() if name == "E" else 1.0

        def at(e: float) -> float:
            b = {k: v.detach() for k, v in a.items()}
            b[name] = base + e * scale * d
            with torch.no_grad():
                return float(loss_of(b))
        fd = (at(eps) - at(-eps)) / (2 * eps * scale)
        an = float((a[name].grad * d).sum())
        assert abs(an - fd) <= 1e-5 * abs(fd), (name, an, fd)


def test_dtype_retain_graph_and_the_tape() -> None:
    E = torch.tensor([2e5], dtype=torch.float32, requires_grad=True)
    X, V = dga.simulate(make_world, H, STEPS, params={"youngs_modulus": E})
    L = X[-1, :, 1].sum() + (V[-1] ** 2).sum()
    L.backward(retain_graph=True)
    g1 = E.grad.clone()
    assert E.grad.dtype == torch.float32
    E.grad = None
    L.backward()
    assert torch.equal(g1, E.grad)
    # the same run through the Tape directly
    w = make_world({"youngs_modulus": np.array([2e5], dtype=np.float32).astype(np.float64)})
    tape = w.record()
    xs, vs = [w.positions.copy()], [w.velocities.copy()]
    for _ in range(STEPS):
        w.step(H)
        xs.append(w.positions.copy())
        vs.append(w.velocities.copy())
    dx = np.zeros((STEPS + 1,) + xs[0].shape)
    dv = np.zeros_like(dx)
    dx[-1, :, 1] = 1.0
    dv[-1] = 2 * vs[-1]
    ref = tape.backward(dL_dx=dx, dL_dv=dv, params=["youngs_modulus"])["youngs_modulus"]
    assert float(g1[0]) == pytest.approx(float(ref[0]), rel=1e-6)   # float32 of the same


def test_bad_params() -> None:
    with pytest.raises(ValueError):
        dga.simulate(make_world, H, 1, params={"youngs": torch.ones(1, dtype=torch.float64)})
