# SPDX-License-Identifier: MIT
"""Zero-copy, read-only access to a world's state (``World.state_view()``)."""
from __future__ import annotations

from typing import Any, Dict, Optional, Tuple

import numpy as np

from ._coupling import ElementStress
from ._errors import StaleViewError, Status
from ._native import ffi, lib

__all__ = ["StateView"]


def _alias(ptr: Any, n: int) -> np.ndarray:
    """A read-only (n, 3) float64 array over a C buffer of the world (no copy)."""
    if n == 0 or ptr == ffi.NULL:
        a = np.zeros((0, 3))
    else:
        a = np.frombuffer(ffi.buffer(ptr, 24 * n), dtype=np.float64).reshape(n, 3)
    a.flags.writeable = False
    return a


class StateView:
    """Read-only numpy views of a world's positions and velocities that alias the library's
    own arrays (``defsim_world_state_view``): no copy is made, and the arrays see every change
    of the state (a step, ``set_state``, ``pin``) as it happens. Made by ``World.state_view()``.

    Valid until the world's bodies change (``add_body``, ``remove_body``, which move the state
    into new arrays) or the world is closed. The view checks that on every access and raises
    StaleViewError after such a call; the arrays it handed out cannot check themselves, so read
    them again through the view rather than keeping them past such a call (their memory is
    freed then). They are read-only (``flags.writeable`` False; set the state with
    ``World.set_state``). Copies stay the default elsewhere (``World.positions`` and friends).

    DLPack: the arrays are numpy arrays, so ``np.from_dlpack(view.positions)`` (or any consumer
    of DLPack 1.0, which can mark a tensor read-only) shares their memory; ``__dlpack__`` and
    ``__dlpack_device__`` are numpy's. Consumers of older DLPack versions get numpy's
    BufferError for a read-only array: copy first.

    Stresses are not held by the world: ``element_stress(body)`` computes them into the view's
    own buffers once per state (again after the state changes), read-only, with the same
    validity.
    """

    __slots__ = ("_world", "_layout", "_x", "_v", "_stress")

    def __init__(self, world: Any) -> None:
        w = world._live()
        x = ffi.new("const double **")
        v = ffi.new("const double **")
        n = ffi.new("int32_t *")
        world._check(lib.defsim_world_state_view(w, x, v, n))
        self._world = world
        self._layout = world._layout
        self._x = _alias(x[0], int(n[0]))
        self._v = _alias(v[0], int(n[0]))
        self._stress: Dict[Tuple[int, int], Tuple[int, ElementStress]] = {}

    @property
    def valid(self) -> bool:
        """False once the world's bodies changed or the world was closed."""
        w = self._world
        return w._ptr is not None and w._layout == self._layout

    def _checked(self) -> None:
        if not self.valid:
            raise StaleViewError("this StateView is stale: the world's bodies changed "
                                 "(add_body, remove_body) or it was closed, which moves or frees "
                                 "the state; take a new one with World.view()", Status.STALE_ID)

    @property
    def positions(self) -> np.ndarray:
        """The positions, (n, 3) in m: a read-only array over the world's memory."""
        self._checked()
        return self._x

    @property
    def velocities(self) -> np.ndarray:
        """The velocities, (n, 3) in m/s: a read-only array over the world's memory."""
        self._checked()
        return self._v

    def element_stress(self, body: Any) -> ElementStress:
        """``Body.element_stress()`` of one of the world's bodies, computed into buffers this
        view keeps (once per state: a step or set_state makes the next call compute again)
        and returned read-only."""
        self._checked()
        w = self._world
        cid = w._own(body)
        now = w._state_version
        cached = self._stress.get(body.id)
        if cached is not None and cached[0] == now:
            return cached[1]
        m = w._tet_count(body)
        if cached is not None and cached[1].von_mises.shape[0] == m:
            out = cached[1]
            for a in out:
                a.flags.writeable = True
        else:
            out = ElementStress(np.zeros((m, 3, 3)), np.zeros(m), np.zeros(m))
        ptr = (lambda a: ffi.from_buffer("double[]", a) if a.size else ffi.NULL)
        try:
            w._check(lib.defsim_body_element_stress(w._live(), cid, ptr(out.cauchy),
                                                    ptr(out.von_mises),
                                                    ptr(out.energy_density), m))
        finally:
            for a in out:
                a.flags.writeable = False
        self._stress[body.id] = (now, out)
        return out

    def __repr__(self) -> str:
        state = "valid" if self.valid else "stale"
        return f"<defsim.StateView {state} vertices={self._x.shape[0]}>"
