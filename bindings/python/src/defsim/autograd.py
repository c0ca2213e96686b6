# SPDX-License-Identifier: MIT
"""PyTorch's autograd over a defsim run (docs/gradients.md, "PyTorch"): ``simulate`` runs a world
for a number of steps and returns its trajectory as tensors whose backward pass is one
``Tape.backward``. Needs torch (the ``torch`` extra: ``pip install defsim-fem[torch]``); importing
this module without it raises ImportError. ``import defsim`` never imports torch.

    import torch, defsim.autograd as dga
    E = torch.tensor([1e6], dtype=torch.float64, requires_grad=True)
    X, V = dga.simulate(lambda p: make_world(p["youngs_modulus"][0]), h=1e-2, steps=60,
                        params={"youngs_modulus": E})
    loss = X[-1, tip, 1].mean()
    loss.backward()            # E.grad = dL/dE

Every input tensor is read as float64 on the CPU; the gradients come back in each input's dtype
and device. The trajectory X, V has shape (steps + 1, n, 3) (state 0 is the start), float64 on
the CPU."""
from __future__ import annotations

from typing import Any, Callable, Dict, Optional, Sequence, Tuple

import numpy as np

try:
    import torch
except ImportError as exc:   # pragma: no cover - exercised only without torch
    raise ImportError("defsim.autograd needs torch (pip install defsim-fem[torch])") from exc

from ._tape import BODY_PARAMS

__all__ = ["simulate", "Simulate"]


def _array(t: Optional["torch.Tensor"]) -> Optional[np.ndarray]:
    return None if t is None else t.detach().to("cpu", torch.float64).numpy()


class Simulate(torch.autograd.Function):
    """The autograd Function behind ``simulate`` (use that). Inputs after the non-tensor
    arguments: x0 (n, 3), v0 (n, 3), external_forces (N, n, 3), pin_targets (N, k, 3), then
    the per-body parameter tensors (b,) in the order of ``names``; each may be None."""

    @staticmethod
    def forward(ctx: Any, make_world: Callable[[Dict[str, np.ndarray]], Any], h: float,
                steps: int, names: Tuple[str, ...], pins: Optional[Tuple[int, Any]],
                interval: int, x0: Optional["torch.Tensor"], v0: Optional["torch.Tensor"],
                external_forces: Optional["torch.Tensor"],
                pin_targets: Optional["torch.Tensor"], *params: "torch.Tensor"):
        values = {name: _array(p) for name, p in zip(names, params)}
        world = make_world(values)
        x = _array(x0)
        v = _array(v0)
        if x is not None or v is not None:
            world.set_state(x, v)
        f = _array(external_forces)
        g = _array(pin_targets)
        body = verts = None
        if g is not None:   # pinned before the recording, which follows one set of pins
            body, verts = world.bodies[pins[0]], np.asarray(pins[1])
            world.pin(body, verts)
        tape = world.record(interval=interval)
        X = [world.positions.copy()]
        V = [world.velocities.copy()]
        for s in range(steps):
            if f is not None:
                world.set_external_forces(f[s])
            if g is not None:
                body.set_pin_targets(verts, g[s])
            world.step(h)
            X.append(world.positions.copy())
            V.append(world.velocities.copy())
        ctx.run = (world, tape, names, pins)
        ctx.wants = (x0 is not None, v0 is not None, external_forces is not None,
                     pin_targets is not None)
        ctx.like = (x0, v0, external_forces, pin_targets) + tuple(params)
        return torch.from_numpy(np.stack(X)), torch.from_numpy(np.stack(V))

    @staticmethod
    def backward(ctx: Any, gX: Optional["torch.Tensor"], gV: Optional["torch.Tensor"]):
        world, tape, names, pins = ctx.run
        want = []
        for flag, name in zip(ctx.wants, ("initial_positions", "initial_velocities",
                                          "external_forces", "pin_targets")):
            if flag:
                want.append(name)
        want += list(names)
        grads = tape.backward(dL_dx=_array(gX), dL_dv=_array(gV), params=want)
        out = []
        for name, like in zip(("initial_positions", "initial_velocities", "external_forces",
                               "pin_targets") + tuple(names), ctx.like):
            if like is None:
                out.append(None)
                continue
            gr = grads[name]
            if name == "pin_targets":
                gr = gr[:, world.bodies[pins[0]].vertex_offset + np.asarray(pins[1])]
            out.append(torch.from_numpy(np.ascontiguousarray(gr)).to(like.device, like.dtype))
        return (None,) * 6 + tuple(out)


def simulate(make_world: Callable[[Dict[str, np.ndarray]], Any], h: float, steps: int, *,
             params: Optional[Dict[str, "torch.Tensor"]] = None,
             x0: Optional["torch.Tensor"] = None, v0: Optional["torch.Tensor"] = None,
             external_forces: Optional["torch.Tensor"] = None,
             pin_targets: Optional[Tuple[int, Sequence[int], "torch.Tensor"]] = None,
             interval: int = 0) -> Tuple["torch.Tensor", "torch.Tensor"]:
    """Runs a world for `steps` steps of `h` (s) and returns its positions and velocities at
    the states 0 .. steps as tensors X, V of shape (steps + 1, n, 3), differentiable with
    respect to the tensors given:

    - params: per-body parameters by name (youngs_modulus, poisson_ratio, density,
      mass_damping, stiffness_damping, body_friction), tensors of shape (b,). make_world(values) builds the
      world from their values ({name: float64 array (b,)}) each time the function runs.
    - x0, v0: the initial state (n, 3) (set with ``World.set_state``; None: the world's).
    - external_forces: (steps, n, 3), held during each step (``World.set_external_forces``).
    - pin_targets: (body index, vertices (k,), targets (steps, k, 3)): the driven pins of that
      body (pinned before the recording begins), given their targets before each step
      (``Body.set_pin_targets``).

    The world and its recording (``World.record(interval)``) live until the graph is freed;
    backward runs ``Tape.backward`` once (it may run again with retain_graph). Raises what
    World and Tape raise (UnsupportedError for a backend or scene that cannot be
    differentiated)."""
    params = dict(params or {})
    for name in params:
        if name not in BODY_PARAMS:
            raise ValueError(f"params: {name!r} is not one of {', '.join(BODY_PARAMS)}")
    names = tuple(params)
    pins = None
    targets = None
    if pin_targets is not None:
        pins = (int(pin_targets[0]), tuple(int(i) for i in pin_targets[1]))
        targets = pin_targets[2]
    return Simulate.apply(make_world, float(h), int(steps), names, pins, int(interval), x0, v0,
                          external_forces, targets, *(params[n] for n in names))
