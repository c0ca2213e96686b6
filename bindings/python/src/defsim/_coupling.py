# SPDX-License-Identifier: MIT
"""Coupling a world with its host: external forces, a Python force callback, driven pins,
attachments, and what the host reads back (pin forces, attachment forces, element stress).

The methods here are those of ``World`` and ``Body`` (mixed in); ``Attachment`` is the handle
that ``World.add_attachment`` returns.
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple, Optional

import numpy as np

from . import _arrays
from ._errors import CallbackError, InvalidArgumentError, Status
from ._handle import Handle
from ._native import ffi, lib

__all__ = ["Attachment", "ElementStress", "ForceCallback", "ForceJacobian", "StepError"]

#: fn(x, v, t) -> forces (n, 3) in N to add, at positions x (m) and velocities v (m/s), both
#: (n, 3) read-only arrays valid only during the call, at time t (s).
ForceCallback = Callable[[np.ndarray, np.ndarray, float], Any]
#: jacobian(x, v, t) -> (n, 3, 3) blocks dF_i/dx_i (N/m).
ForceJacobian = Callable[[np.ndarray, np.ndarray, float], Any]


class StepError(CallbackError):
    """A call failed because the Python force callback (or its Jacobian) raised: the step (or
    ``pin_forces()``) was abandoned and the world's state is as before it. The exception the
    callback raised is chained as ``__cause__``. Status ``Status.CALLBACK``."""


class ElementStress(NamedTuple):
    """Per-tet stress of a body at the current state (``Body.element_stress``)."""

    cauchy: np.ndarray          #: Cauchy stress sigma = P F^T / det F, (m, 3, 3), Pa
    von_mises: np.ndarray       #: sqrt(3/2 s : s), s the deviator of sigma, (m,), Pa
    energy_density: np.ndarray  #: strain energy density relative to rest, (m,), J/m^3


def _view(ptr: Any, n: int, writable: bool = False) -> np.ndarray:
    """An (n, 3) float64 view of a C buffer (no copy); read-only unless `writable`."""
    a = np.frombuffer(ffi.buffer(ptr, 24 * n), dtype=np.float64).reshape(n, 3)
    if not writable:
        a.flags.writeable = False
    return a


class _ForceCallback:
    """Keeps a Python force callback and its cffi trampolines alive; remembers the first
    exception raised inside, which the failing call then re-raises as StepError."""

    def __init__(self, fn: ForceCallback, jacobian: Optional[ForceJacobian]) -> None:
        self.fn = fn
        self.jacobian = jacobian
        self.error: Optional[BaseException] = None
        # Views of the C buffers by (address, n, writable): the world passes the same buffers
        # at every evaluation, and making a view costs more than the rest of the trampoline.
        self._views: dict = {}
        self.c_fn = ffi.callback("defsim_force_fn", self._force)
        self.c_jac = ffi.callback("defsim_force_jacobian_fn", self._jac) if jacobian else ffi.NULL

    def _cached(self, ptr: Any, n: int, writable: bool = False) -> np.ndarray:
        key = (int(ffi.cast("uintptr_t", ptr)), n, writable)
        a = self._views.get(key)
        if a is None:
            if len(self._views) > 16:
                self._views.clear()
            a = self._views[key] = _view(ptr, n, writable)
        return a

    def _force(self, user: Any, x: Any, v: Any, t: float, n: int, f: Any) -> int:
        try:
            r = self.fn(self._cached(x, n), self._cached(v, n), float(t))
            if type(r) is not np.ndarray or r.dtype != np.float64:
                r = np.asarray(r, dtype=np.float64)
            if r.shape != (n, 3):
                if r.size != 3 * n:
                    raise InvalidArgumentError(f"the force callback returned shape {r.shape}, "
                                               f"expected ({n}, 3)")
                r = r.reshape(n, 3)
            fa = self._cached(f, n, writable=True)
            fa += r
            return 0
        except BaseException as exc:  # never let an exception cross into C
            if self.error is None:
                self.error = exc
            return 1

    def _jac(self, user: Any, x: Any, v: Any, t: float, n: int, blocks: Any) -> int:
        try:
            r = np.asarray(self.jacobian(self._cached(x, n), self._cached(v, n), float(t)),
                           dtype=np.float64)
            if r.size != 9 * n:
                raise InvalidArgumentError(f"the force Jacobian returned shape {r.shape}, "
                                           f"expected ({n}, 3, 3)")
            np.frombuffer(ffi.buffer(blocks, 72 * n), dtype=np.float64)[...] = r.reshape(-1)
            return 0
        except BaseException as exc:
            if self.error is None:
                self.error = exc
            return 1

    def reraise(self, status: int, message: str) -> None:
        """Raises StepError from the stored exception, if the failure was the callback's."""
        exc, self.error = self.error, None
        if exc is not None:
            raise StepError(f"the force callback raised {type(exc).__name__}: {exc} ({message})",
                            Status.CALLBACK) from exc


class Attachment(Handle):
    """A zero-rest-length spring from a vertex to a world point or to a point of another body
    (``World.add_attachment``): a small handle like Body. After ``remove()``, or when a body it
    joins is removed, it is stale and its methods raise StaleIdError."""

    __slots__ = ()
    _ctype = "defsim_attachment_id *"

    def set_target(self, point: Any) -> None:
        """Moves the attachment's world point to `point` (m); an attachment to a body becomes
        one to this world point. The point is held in the steps that follow. Raises
        InvalidArgumentError (non-finite), StaleIdError."""
        p = np.array(_arrays.triple(point, "point"))
        w = self._world
        w._check(lib.defsim_attachment_set_target(w._live(), self._cid(), _arrays.dptr(p)))

    @property
    def force(self) -> np.ndarray:
        """The force (N, shape (3,)) the spring applies to its vertex at the current state:
        -k (x - p) - c (v - v_p). Its target receives the opposite."""
        out = np.zeros(3)
        w = self._world
        w._check(lib.defsim_world_get_attachment_force(w._live(), self._cid(), _arrays.dptr(out)))
        return out

    def remove(self) -> None:
        """Removes the attachment; this handle becomes stale."""
        w = self._world
        w._check(lib.defsim_world_remove_attachment(w._live(), self._cid()))


class WorldCoupling:
    """World methods for coupling (mixed into ``World``)."""

    _force_callback: Optional[_ForceCallback] = None

    def _callback_failed(self, status: int, message: str) -> None:
        cb = self._force_callback
        if cb is not None and status == Status.CALLBACK:
            cb.reraise(status, message)
        exc = self._sdf_failed() if status == Status.CALLBACK else None   # type: ignore[attr-defined]
        if exc is not None:
            raise StepError(f"a collider's sdf raised {type(exc).__name__}: {exc} ({message})",
                            Status.CALLBACK) from exc

    def set_external_forces(self, forces: Any) -> None:
        """Holds one external force per vertex, (n, 3) in N in world vertex order (copied),
        in every step until changed; None clears them. They are a constant force field: part of
        ``energy().gravitational`` and treated exactly by implicit backends. Raises
        InvalidArgumentError (shape, non-finite value; the forces held before stay)."""
        w = self._live()
        if forces is None:
            self._check(lib.defsim_world_set_external_forces(w, ffi.NULL, 0))
            return
        n = int(lib.defsim_world_vertex_count(w))
        f = _arrays.points(forces, "forces", n)
        self._check(lib.defsim_world_set_external_forces(w, _arrays.dptr(f), n))

    def set_force_callback(self, fn: Optional[ForceCallback],
                           jacobian: Optional[ForceJacobian] = None) -> None:
        """Sets a Python force callback: ``fn(x, v, t)`` returns forces (n, 3) in N that are
        added to the world's at every force evaluation; ``jacobian(x, v, t)`` optionally returns
        the per-vertex blocks dF_i/dx_i, (n, 3, 3) in N/m, so that implicit backends treat the
        force implicitly (without one they hold the force of the step's start constant over
        the step). ``fn=None`` clears it. x and v are read-only views valid during the call:
        copy them to keep them.

        Cost: each evaluation is a call from C into Python through cffi, array views of the C
        buffers (cached) and one addition: about 16 (2 vertices) to 35 (1,000 vertices)
        microseconds besides ``fn``'s own work on the shared build machine
        (``python bindings/python/bench_callback.py``), paid at every force evaluation: once
        per step for the Euler methods, per internal step for adaptive ones, per Newton iterate
        for implicit ones with a Jacobian.
        For large worlds vectorise ``fn`` with numpy; for fixed forces use
        ``set_external_forces``, which costs nothing per evaluation in Python.

        An exception raised inside fn or jacobian fails the step cleanly: the C callback returns
        failure, the step returns DEFSIM_ERR_CALLBACK with the state unchanged, and ``step()``
        raises StepError from the exception (``__cause__``)."""
        w = self._live()
        if fn is None:
            if jacobian is not None:
                raise InvalidArgumentError("a jacobian needs a force callback")
            self._check(lib.defsim_world_set_force_callback(w, ffi.NULL, ffi.NULL, ffi.NULL))
            self._force_callback = None
            return
        if not callable(fn) or (jacobian is not None and not callable(jacobian)):
            raise InvalidArgumentError("fn and jacobian must be callable(x, v, t)")
        cb = _ForceCallback(fn, jacobian)
        self._check(lib.defsim_world_set_force_callback(w, cb.c_fn, cb.c_jac, ffi.NULL))
        self._force_callback = cb   # the trampolines live as long as the world uses them

    def add_attachment(self, body: Any, vertex: int, target: Any = None, *,
                       stiffness: float = 1e3, damping: float = 0.0,
                       target_body: Any = None, target_vertices: Any = None,
                       target_weights: Any = None) -> Attachment:
        """Adds a zero-rest-length spring (k N/m, optional damping c N s/m) from body-local
        `vertex` of `body` either to the world point `target` (m; default: the vertex's current
        position), or, with `target_body`, to the point sum_j w_j x[v_j] of `target_vertices`
        (1 to 4 body-local vertices of target_body: a vertex, an edge, a triangle or a tet)
        with barycentric `target_weights` (summing to 1). Returns an Attachment.
        Raises InvalidArgumentError, StaleIdError; on error the world is unchanged."""
        w = self._live()
        cid = self._own(body)
        d = ffi.new("defsim_attachment_def *")
        lib.defsim_attachment_def_init(d, ffi.sizeof("defsim_attachment_def"))
        d.body = cid
        d.vertex = _arrays.c_int(vertex, "vertex")
        d.stiffness = _arrays.c_double(stiffness, "stiffness")
        d.damping = _arrays.c_double(damping, "damping")
        if target_body is not None:
            if target is not None:
                raise InvalidArgumentError("give target (a world point) or target_body, not both")
            d.target_body = self._own(target_body)
            tv = _arrays.indices(target_vertices, "target_vertices", 1).reshape(-1)
            if not 1 <= tv.size <= 4:
                raise InvalidArgumentError("target_vertices: 1 to 4 vertices")
            tw = _arrays.vector(target_weights, "target_weights", tv.size)
            d.target_vertex_count = int(tv.size)
            for j in range(tv.size):
                d.target_vertices[j] = int(tv[j])
                d.target_weights[j] = float(tw[j])
        else:
            if target is None:
                off = body.vertex_offset
                n = body.vertex_count
                if not 0 <= int(vertex) < n:
                    raise InvalidArgumentError(f"vertex {vertex} out of range [0, {n})")
                target = self.positions[off + int(vertex)]
            d.target = list(_arrays.triple(target, "target"))
        out = ffi.new("defsim_attachment_id *")
        self._check(lib.defsim_world_add_attachment(w, d, out))
        return Attachment(self, int(out.index), int(out.generation))

    def pin_forces(self) -> np.ndarray:
        """Reaction forces of the pins, (n, 3) in N: for each pinned or driven vertex the force
        its support applies to the body (m a - f at the current state); zero for free vertices.
        At static equilibrium they sum to minus the applied forces (a hanging body: its weight,
        pointing up). Evaluates the forces once (and the force callback, if set: an exception
        there raises StepError)."""
        w = self._live()
        n = int(lib.defsim_world_vertex_count(w))
        out = np.zeros((n, 3))
        if n > 0:
            self._check(lib.defsim_world_get_pin_forces(w, _arrays.dptr(out), n))
        return out

    def pinned(self) -> np.ndarray:
        """The pinned flags, (n,) bool: True for pinned and driven vertices
        (``defsim_world_get_pinned``)."""
        w = self._live()
        n = int(lib.defsim_world_vertex_count(w))
        out = np.zeros(n, np.uint8)
        if n > 0:
            self._check(lib.defsim_world_get_pinned(w, ffi.from_buffer("uint8_t[]", out), n))
        return out.astype(bool)


class BodyCoupling:
    """Body methods for coupling (mixed into ``Body``)."""

    __slots__ = ()

    def set_pin_targets(self, vertices: Any, positions: Any) -> None:
        """Drives vertices (body-local indices, pinned by this call if they were not): each
        reaches its row of `positions` ((k, 3), m) exactly at the end of the next step, moving
        with constant velocity over it, then stays there unless given a new target. Raises
        InvalidArgumentError (index out of range, non-finite position), StaleIdError; on error
        nothing changes."""
        w = self._world
        cid = w._own(self)
        v = w._vertex_list(self, vertices)
        p = _arrays.points(positions, "positions", int(v.size))
        w._check(lib.defsim_body_set_pin_targets(w._live(), cid, _arrays.iptr(v), int(v.size),
                                                 _arrays.dptr(p)))

    def element_stress(self) -> ElementStress:
        """Per-tet Cauchy stress, von Mises stress and strain energy density at the current
        state, in the order of the body's tets (empty for a body without tets). All zero at
        rest; NaN for a tet with det F = 0 (or <= 0 under neo-Hookean)."""
        w = self._world
        cid = w._own(self)
        m = w._tet_count(self)
        cauchy = np.zeros((m, 3, 3))
        vm = np.zeros(m)
        psi = np.zeros(m)
        w._check(lib.defsim_body_element_stress(w._live(), cid, _arrays.dptr(cauchy),
                                                _arrays.dptr(vm), _arrays.dptr(psi), m))
        return ElementStress(cauchy, vm, psi)
