# SPDX-License-Identifier: MIT
"""Gradients through a run (docs/gradients.md): ``tape = world.record()``, step the world as
usual, then ``tape.backward(dL_dx=..., dL_dv=...)`` returns the loss's gradients by name."""
from __future__ import annotations

from typing import Any, Dict, Optional, Sequence

import numpy as np

from ._errors import InvalidArgumentError, error_from_status
from ._native import ffi, lib

#: The gradients a backward pass can fill: per vertex (shape (n, 3)) and per body (shape (b,)).
VERTEX_PARAMS = ("initial_positions", "initial_velocities")
BODY_PARAMS = ("youngs_modulus", "poisson_ratio", "density", "mass_damping",
               "stiffness_damping", "body_friction")
#: Per step (shape (N, n, 3)): the held external forces of each recorded step and the driven
#: pins' targets given for it (the controls).
STEP_PARAMS = ("external_forces", "pin_targets")
#: Per attachment (shape (a,)) and per step and attachment (shape (N, a, 3)): world targets.
ATTACHMENT_PARAMS = ("attachment_stiffness", "attachment_damping")
ATTACHMENT_STEP_PARAMS = ("attachment_targets",)
#: Per collider (shape (c,), in ``World.colliders``' order): the friction coefficient mu.
COLLIDER_PARAMS = ("collider_friction",)
#: Per state and collider (shape (N + 1, c, 6)): the colliders' poses over time, each as the
#: translation dp and the small rotation dtheta (world frame, about the collider's origin).
COLLIDER_STATE_PARAMS = ("collider_poses",)


class Tape:
    """A recording of a world's steps (``World.record``). Every successful ``World.step``
    after it is recorded until ``close()``. Keeps its world alive."""

    def __init__(self, world: Any, interval: int = 0, max_bytes: Optional[int] = None) -> None:
        d = ffi.new("defsim_tape_def *")
        lib.defsim_tape_def_init(d, ffi.sizeof("defsim_tape_def"))
        d.interval = int(interval)
        if max_bytes is not None:
            d.max_bytes = int(max_bytes)
        out = ffi.new("defsim_tape **")
        world._check(lib.defsim_world_record(world._live(), d, out))
        self._world = world
        self._ptr = ffi.gc(out[0], lib.defsim_tape_destroy)

    def close(self) -> None:
        """Ends the recording (the world steps on unrecorded). Closing twice is allowed."""
        if self._ptr is not None:
            ptr, self._ptr = self._ptr, None
            ffi.release(ptr)

    def __enter__(self) -> "Tape":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def _live(self) -> Any:
        if self._ptr is None:
            raise InvalidArgumentError("the tape is closed")
        return self._ptr

    def _check(self, status: int) -> None:
        if status < 0:
            msg = ffi.string(lib.defsim_tape_last_error(self._ptr)).decode("utf-8", "replace")
            raise error_from_status(status, msg)

    def stats(self) -> Dict[str, Any]:
        """steps, stored_states, interval, bytes (the tape's memory), backward_bytes,
        recomputed_steps, time_forward, time_backward, time_recompute (s)."""
        s = ffi.new("defsim_tape_stats *")
        s.size = ffi.sizeof("defsim_tape_stats")
        self._check(lib.defsim_tape_get_stats(self._live(), s))
        names = ("steps", "stored_states", "interval", "bytes", "backward_bytes",
                 "recomputed_steps", "time_forward", "time_backward", "time_recompute")
        return {k: getattr(s, k) for k in names}

    @property
    def steps(self) -> int:
        """Recorded steps N (the states 0 .. N)."""
        return int(self.stats()["steps"])

    def backward(self, dL_dx: Optional[np.ndarray] = None, dL_dv: Optional[np.ndarray] = None,
                 params: Optional[Sequence[str]] = None) -> Dict[str, np.ndarray]:
        """The gradients of a loss L of the recorded states, given dL/dx_s and dL/dv_s at every
        state s = 0 .. N as arrays of shape (N + 1, n, 3) (or (N + 1, 3 n); None: zero).
        Returns {name: gradient} for `params` (default: all): "initial_positions" and
        "initial_velocities" of shape (n, 3), and per body (in the world's order) of shape (b,):
        "youngs_modulus", "poisson_ratio", "density", "mass_damping", "stiffness_damping",
        "body_friction" (body contact's mu);
        and "external_forces" of shape (N, n, 3), dL/df_j of the forces held during step j
        (``World.set_external_forces``; also where they were zero), and "pin_targets" of
        shape (N, n, 3), dL/dp_j of the targets ``Body.set_pin_targets`` gave for step j (0 at
        the vertices it did not drive then); with attachments,
        "attachment_stiffness" and "attachment_damping" of shape (a,) and "attachment_targets"
        of shape (N, a, 3) (world-point targets held during each step); with colliders,
        "collider_friction" of shape (c,) (dL/dmu of each collider) and "collider_poses" of
        shape (N + 1, c, 6): dL/d of each collider's pose at state s (where
        ``Collider.set_pose`` put it for step s - 1, the pose at the recording's start for
        s = 0), as (dp, dtheta), the pose moved to (p + dp, (I + [dtheta]) R).
        The world is left as it was. Raises InvalidArgumentError (wrong shape, non-finite
        values, the world changed since recording began), UnsupportedError."""
        w = self._world
        n = w.vertex_count
        N = self.steps
        shape = (N + 1) * 3 * n
        arrays = []
        for name, a in (("dL_dx", dL_dx), ("dL_dv", dL_dv)):
            if a is None:
                arrays.append(None)
                continue
            a = np.ascontiguousarray(a, dtype=np.float64)
            if a.size != shape:
                raise InvalidArgumentError(
                    f"{name} has {a.size} values; the {N + 1} recorded states of {n} vertices "
                    f"need shape ({N + 1}, {n}, 3)")
            arrays.append(a.reshape(-1))
        na = int(lib.defsim_world_attachment_count(w._live()))
        nc = int(lib.defsim_world_collider_count(w._live()))
        names = (list(params) if params is not None
                 else list(VERTEX_PARAMS + BODY_PARAMS + STEP_PARAMS +
                           (ATTACHMENT_PARAMS + ATTACHMENT_STEP_PARAMS if na else ()) +
                           (COLLIDER_PARAMS + COLLIDER_STATE_PARAMS if nc else ())))
        nb = len(w.bodies)
        outs, keep = {}, []
        g = ffi.new("defsim_gradient[]", max(len(names), 1))
        for i, name in enumerate(names):
            out = np.zeros((n, 3) if name in VERTEX_PARAMS
                           else (N, n, 3) if name in STEP_PARAMS
                           else (na,) if name in ATTACHMENT_PARAMS
                           else (nc,) if name in COLLIDER_PARAMS
                           else (N + 1, nc, 6) if name in COLLIDER_STATE_PARAMS
                           else (N, na, 3) if name in ATTACHMENT_STEP_PARAMS else (nb,))
            c = ffi.new("char[]", str(name).encode())
            keep.append(c)
            g[i].name = c
            g[i].out = ffi.from_buffer("double[]", out) if out.size else ffi.NULL
            g[i].count = out.size
            outs[name] = out
        ptr = [ffi.from_buffer("double[]", a) if a is not None else ffi.NULL for a in arrays]
        self._check(lib.defsim_tape_backward(self._live(), ptr[0], ptr[1], shape, g, len(names)))
        return outs
