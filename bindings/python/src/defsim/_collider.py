# SPDX-License-Identifier: MIT
"""Colliders: shapes the host places and moves, which push on the bodies (``defsim_collider_*``).
The methods here are those of ``World`` (mixed in); ``Collider`` is the handle that
``World.add_collider`` returns."""
from __future__ import annotations

import enum
from typing import Any, Callable, List, NamedTuple, Optional, Tuple, Union

import numpy as np

from . import _arrays
from ._errors import InvalidArgumentError, StaleIdError, Status
from ._handle import Handle
from ._native import ffi, lib

__all__ = ["Collider", "Shape", "Pose", "SdfCallback"]

#: sdf(p) -> (distance, gradient): signed distance (m, < 0 inside) of the local point p ((3,)
#: array) and its unit outward gradient (3 numbers).
SdfCallback = Callable[[np.ndarray], Tuple[float, Any]]


class Shape(enum.IntEnum):
    """Collider shapes (``defsim_shape``), each in its own frame placed by the pose."""

    PLANE = 0     #: half-space below the plane through the origin with outward `normal`
    SPHERE = 1    #: ball of `radius` about the origin
    BOX = 2       #: box of `half_extents` about the origin
    CAPSULE = 3   #: points within `radius` of the segment (0, +-half_height, 0)
    MESH = 4      #: static triangle mesh (`vertices`, `triangles`)
    SDF = 5       #: signed distance from a Python callable `sdf`


class Pose(NamedTuple):
    """A collider's placement: position (m) and rotation quaternion (w, x, y, z)."""

    position: Tuple[float, float, float]
    rotation: Tuple[float, float, float, float]


def _shape(value: Union[str, int, Shape]) -> Shape:
    if isinstance(value, str):
        try:
            return Shape[value.strip().upper()]
        except KeyError:
            raise InvalidArgumentError(f"unknown shape {value!r}; one of "
                                       f"{', '.join(s.name.lower() for s in Shape)}") from None
    try:
        return Shape(int(value))
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"unknown shape {value!r}") from None


def _quat(value: Any) -> List[float]:
    q = np.asarray(value, dtype=np.float64).reshape(-1)
    if q.shape[0] != 4:
        raise InvalidArgumentError("rotation: expected a quaternion (w, x, y, z)")
    return [float(c) for c in q]


class Collider(Handle):
    """A collider of a World (``World.add_collider``): a small handle like Body. After
    ``remove()`` it is stale and its methods raise StaleIdError."""

    __slots__ = ()
    _ctype = "defsim_collider_id *"

    def set_pose(self, position: Any, rotation: Any = None) -> None:
        """Same as ``World.set_collider_pose(self, position, rotation)``."""
        self._world.set_collider_pose(self, position, rotation)

    def remove(self) -> None:
        """Same as ``World.remove_collider(self)``."""
        self._world.remove_collider(self)

    def _def(self) -> Any:
        w = self._world
        ptr = w._live()
        cid = ffi.new("defsim_collider_id *")
        d = ffi.new("defsim_collider_def *")
        lib.defsim_collider_def_init(d, ffi.sizeof("defsim_collider_def"))
        for i in range(int(lib.defsim_world_collider_count(ptr))):
            w._check(lib.defsim_world_get_collider(ptr, i, cid, d))
            if (int(cid.index), int(cid.generation)) == self.id:
                return d
        raise StaleIdError(f"collider {self.id} is removed", Status.STALE_ID)

    @property
    def shape(self) -> Shape:
        return Shape(int(self._def().shape))

    @property
    def pose(self) -> Pose:
        """The current pose (the target of the last completed step). Raises StaleIdError."""
        d = self._def()
        return Pose(tuple(float(c) for c in d.position), tuple(float(c) for c in d.rotation))

    @property
    def friction(self) -> float:
        return float(self._def().friction)

    @property
    def alive(self) -> bool:
        try:
            self._def()
            return True
        except Exception:
            return False


class _Sdf:
    """Keeps a Python SDF and its cffi trampoline alive; an exception inside fails the step."""

    def __init__(self, fn: SdfCallback) -> None:
        self.fn = fn
        self.error: Optional[BaseException] = None
        self.c_fn = ffi.callback("defsim_sdf_fn", self._call)

    def _call(self, user: Any, p: Any, grad: Any) -> float:
        try:
            d, g = self.fn(np.array([p[0], p[1], p[2]]))
            g = [float(c) for c in np.asarray(g, dtype=np.float64).reshape(3)]
            grad[0], grad[1], grad[2] = g
            return float(d)
        except BaseException as exc:   # never unwind through C: a NaN fails the step
            if self.error is None:
                self.error = exc
            return float("nan")


class WorldColliders:
    """World methods for colliders (mixed into ``World``)."""

    def _sdf_failed(self) -> Optional[BaseException]:
        """The first exception a Python SDF raised since the last call, cleared."""
        for cb in self._sdfs.values():
            if cb.error is not None:
                exc, cb.error = cb.error, None
                return exc
        return None

    def add_collider(self, shape: Union[str, int, Shape] = "plane", *, position: Any = None,
                     rotation: Any = None, normal: Any = None, radius: Optional[float] = None,
                     half_extents: Any = None, half_height: Optional[float] = None,
                     friction: Optional[float] = None, vertices: Any = None,
                     triangles: Any = None, sdf: Optional[SdfCallback] = None,
                     sdf_bounds: Any = None) -> Collider:
        """Adds a collider (``defsim_world_add_collider``). Arguments left None keep the
        library's defaults (``defsim_collider_def_init``: a ground plane through the origin,
        normal +y, no friction).

        Args:
            shape: "plane", "sphere", "box", "capsule", "mesh", "sdf" (or a Shape).
            position: origin of the collider's frame (m); rotation: quaternion (w, x, y, z).
            normal: plane's outward normal (local frame). radius: sphere, capsule (m).
            half_extents: box (m). half_height: capsule's axis half length (m).
            friction: Coulomb coefficient mu >= 0.
            vertices, triangles: a mesh collider's (k, 3) points (m) and (t, 3) indices.
            sdf: a mesh-free shape: ``sdf(p) -> (distance, gradient)`` in the local frame;
                an exception inside fails the step (CallbackError, state unchanged).
            sdf_bounds: (lo, hi) local box outside which the SDF is at least the distance to
                the box (vertices outside it are never queried).

        Returns the Collider. Raises InvalidArgumentError (bad values, unknown shape, a shape
        the library does not support yet), LockedError.
        """
        w = self._live()
        s = _shape(shape)
        d = ffi.new("defsim_collider_def *")
        lib.defsim_collider_def_init(d, ffi.sizeof("defsim_collider_def"))
        d.shape = int(s)
        vector = lambda v, name: list(_arrays.triple(v, name))   # noqa: E731
        given = (("position", position, vector), ("rotation", rotation, lambda v, _: _quat(v)),
                 ("normal", normal, vector), ("radius", radius, _arrays.c_double),
                 ("half_extents", half_extents, vector),
                 ("half_height", half_height, _arrays.c_double),
                 ("friction", friction, _arrays.c_double))
        for name, value, convert in given:
            if value is not None:
                setattr(d, name, convert(value, name))
        keep: List[Any] = []
        if vertices is not None or triangles is not None:
            vx = _arrays.points(vertices, "vertices")
            tr = _arrays.indices(triangles, "triangles", 3)
            keep += [vx, tr]
            d.vertices, d.vertex_count = _arrays.dptr(vx), vx.shape[0]
            d.triangles, d.triangle_count = _arrays.iptr(tr), tr.shape[0]
        cb = None
        if sdf is not None:
            if not callable(sdf):
                raise InvalidArgumentError("sdf must be callable(p) -> (distance, gradient)")
            cb = _Sdf(sdf)
            d.sdf = cb.c_fn
        if sdf_bounds is not None:
            b = np.asarray(sdf_bounds, dtype=np.float64).reshape(-1)
            if b.shape[0] != 6:
                raise InvalidArgumentError("sdf_bounds: expected (lo, hi), 6 numbers")
            d.sdf_bounds = [float(c) for c in b]
        out = ffi.new("defsim_collider_id *")
        self._check(lib.defsim_world_add_collider(w, d, out))
        del keep
        c = Collider(self, int(out.index), int(out.generation))
        if cb is not None:
            self._sdfs[c.id] = cb   # the trampoline lives as long as the collider
        return c

    def _own_collider(self, collider: Collider) -> Any:
        if not isinstance(collider, Collider):
            raise InvalidArgumentError("expected a defsim.Collider")
        if collider._world is not self:
            raise StaleIdError(f"collider {collider.id} belongs to another world",
                               Status.STALE_ID)
        return collider._cid()

    def remove_collider(self, collider: Collider) -> None:
        """Removes a collider; its handle goes stale. Raises StaleIdError, LockedError."""
        self._check(lib.defsim_world_remove_collider(self._live(), self._own_collider(collider)))
        self._sdfs.pop(collider.id, None)

    def set_collider_pose(self, collider: Collider, position: Any, rotation: Any = None) -> None:
        """Sets the pose the collider reaches at the end of the next step (position in m,
        rotation a quaternion (w, x, y, z); None keeps the current rotation). During the step
        it moves at constant velocity, so friction carries bodies along. Raises
        InvalidArgumentError (non-finite, quaternion not unit), StaleIdError."""
        cid = self._own_collider(collider)
        p = np.array(_arrays.triple(position, "position"))
        q = np.array(collider.pose.rotation if rotation is None else _quat(rotation))
        self._check(lib.defsim_collider_set_pose(self._live(), cid, _arrays.dptr(p),
                                                 _arrays.dptr(q)))

    @property
    def colliders(self) -> List[Collider]:
        """The live colliders in order of creation (a new list)."""
        w = self._live()
        cid = ffi.new("defsim_collider_id *")
        out = []
        for i in range(int(lib.defsim_world_collider_count(w))):
            self._check(lib.defsim_world_get_collider(w, i, cid, ffi.NULL))
            out.append(Collider(self, int(cid.index), int(cid.generation)))
        return out

    def contact_forces(self) -> np.ndarray:
        """The total contact force (normal + friction, N) the colliders (and, with the option
        core.body_contact, the other bodies and the body itself) applied to each vertex during
        the last step, (n, 3); zero before any step and away from contact."""
        return self._get(lib.defsim_world_get_contact_forces, None, 3, "out")   # type: ignore[attr-defined]
