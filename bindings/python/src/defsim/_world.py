# SPDX-License-Identifier: MIT
"""Worlds and bodies."""
from __future__ import annotations

import dataclasses
import enum
import os
import struct
from typing import Any, Callable, Dict, Iterator, List, Mapping, NamedTuple, Optional, Tuple, Union

import numpy as np

from . import _arrays
from ._collider import WorldColliders
from ._coupling import Attachment, BodyCoupling, WorldCoupling
from ._handle import Handle
from ._errors import (Error, InvalidArgumentError, StaleIdError, Status, UnsupportedError,
                      check, error_from_status)
from ._material import Material
from ._mesh import Mesh, SpringKind
from ._shell import Shell
from ._native import ffi, lib

__all__ = ["World", "Body", "Energy", "Stats", "Pass", "Projection", "LogCallback"]

#: A log sink: called with the level (0 error, 1 warning, 2 info, 3 debug) and the message.
LogCallback = Callable[[int, str], None]


class Projection(enum.IntEnum):
    """How implicit backends make element Hessians positive semi-definite (``defsim_projection``):
    the values of a backend's option ``"<backend>.projection"`` (``set_option`` takes the member
    or its lower-case name)."""

    NONE = 0    #: Exact Hessians (may be indefinite).
    CLAMP = 1   #: Negative eigenvalues set to 0.
    ABS = 2     #: Negative eigenvalues replaced by their absolute value.
    AUTO = 3    #: Exact Hessians while the Newton matrix is positive definite, clamped for an
    #: iteration where it is not (the implicit core's backends: newton_cholmod, newmark, bdf2).


class Pass(enum.IntFlag):
    """Passes a step ran (``Stats.passes``; the ``DEFSIM_PASS_*`` bits)."""

    SPRINGS = 1 << 0
    STVK = 1 << 1
    COROTATED = 1 << 2
    NEOHOOKEAN = 1 << 3
    STABLE_NEOHOOKEAN = 1 << 4
    GRAVITY = 1 << 5
    MASS_DAMPING = 1 << 6
    STIFFNESS_DAMPING = 1 << 7
    PINS = 1 << 8
    HESSIAN = 1 << 9
    ENERGY = 1 << 10
    EXTERNAL_FORCES = 1 << 11
    FORCE_CALLBACK = 1 << 12
    ATTACHMENTS = 1 << 13
    DRIVEN_PINS = 1 << 14
    MEMBRANE = 1 << 15
    BENDING = 1 << 16


class Energy(NamedTuple):
    """Energies of a world's state, in joules (``defsim_energy``)."""

    kinetic: float          #: 1/2 v^T M v
    elastic: float          #: springs plus tets, relative to the rest state
    gravitational: float    #: -sum m g . x (zero at the origin)
    total: float            #: kinetic + elastic + gravitational


@dataclasses.dataclass(frozen=True)
class Stats:
    """Counters and timings of a world, cumulative since creation or ``reset_stats()``
    (``defsim_stats``, the core's; the backend's own counters, such as Newton iterations and
    internal steps, are in ``counters`` by full name). Times are wall-clock seconds."""

    passes: Pass                    #: passes of the last step
    steps: int                      #: successful steps
    failed_steps: int               #: steps that raised (state rolled back)
    threads: int                    #: threads used for assembly
    reordered_tets: int             #: rest tets with negative orientation that were reordered
    time_step: float                #: total time inside step()
    time_forces: float              #: force evaluation
    time_hessian: float             #: stiffness matrix assembly
    force_evals: int
    hessian_evals: int
    energy_evals: int
    substeps: int                   #: backend steps taken by auto_substep
    stable_step: float              #: last stable-step estimate in s (0: none made)
    # The stability watchdog (docs/watchdog.md); the first three of the current state.
    min_volume_ratio: float         #: smallest det F over all tets (1 without tets)
    inverted_elements: int          #: tets with det F <= 0
    energy_drift: float             #: J since the watchdog's reference (nan without one)
    watchdog_trips: int             #: steps the watchdog failed
    #: the backend's counters by full name ("sundials_ida.internal_steps",
    #: "newton_cholmod.newton_iterations", "newton_cholmod.time_factor": value)
    counters: Dict[str, float] = dataclasses.field(default_factory=dict)


def _log_callback(log: LogCallback) -> Any:
    """The C trampoline of a log sink (kept alive by the World that uses it)."""
    if not callable(log):
        raise InvalidArgumentError("log must be callable(level, message)")

    def _sink(user: Any, level: int, message: Any) -> None:
        log(int(level), ffi.string(message).decode("utf-8", "replace"))

    return ffi.callback("defsim_log_fn", _sink)


def _collision_bits(value: Any, what: str) -> int:
    """A collision group or mask: an integer in [0, 2^32)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or \
            not 0 <= int(value) <= 0xFFFFFFFF:
        raise InvalidArgumentError(f"{what} must be an integer in [0, 2^32), got {value!r}")
    return int(value)


class Body(Handle, BodyCoupling):
    """A body of a World: a small handle (index and generation), not the data.

    Obtained from ``World.add_body``; it keeps its world alive. After ``remove()`` (or
    ``World.remove_body``) the handle is stale and its methods raise StaleIdError. Two handles
    compare equal when they name the same body of the same world.
    """

    __slots__ = ()
    _ctype = "defsim_body_id *"

    @property
    def alive(self) -> bool:
        """False once the body was removed or its world closed."""
        w = self._world
        return w._ptr is not None and lib.defsim_body_vertex_count(w._ptr, self._cid()) > 0

    @property
    def vertex_count(self) -> int:
        """Number of vertices. Raises StaleIdError for a removed body."""
        n = lib.defsim_body_vertex_count(self._world._live(), self._cid())
        if n < 0:
            raise self._stale(n)
        return int(n)

    @property
    def vertex_offset(self) -> int:
        """Index of the body's first vertex in the world's arrays (it changes when an earlier
        body is removed)."""
        n = lib.defsim_body_vertex_offset(self._world._live(), self._cid())
        if n < 0:
            raise self._stale(n)
        return int(n)

    @property
    def vertices(self) -> slice:
        """The slice of the world's vertex arrays that this body occupies."""
        off = self.vertex_offset
        return slice(off, off + self.vertex_count)

    @property
    def positions(self) -> np.ndarray:
        """A copy of this body's positions, (n, 3), m."""
        return self._world.positions[self.vertices]

    @property
    def velocities(self) -> np.ndarray:
        """A copy of this body's velocities, (n, 3), m/s."""
        return self._world.velocities[self.vertices]

    def pin(self, vertices: Any) -> None:
        """Same as ``World.pin(self, vertices)``."""
        self._world.pin(self, vertices)

    def unpin(self, vertices: Any) -> None:
        """Same as ``World.unpin(self, vertices)``."""
        self._world.unpin(self, vertices)

    def set_collision(self, self_contact: bool = True, group: int = 1,
                      mask: int = 0xFFFFFFFF) -> None:
        """Same as ``World.set_collision(self, ...)``."""
        self._world.set_collision(self, self_contact, group, mask)

    def remove(self) -> None:
        """Same as ``World.remove_body(self)``."""
        self._world.remove_body(self)

    def _stale(self, status: int) -> Error:
        return error_from_status(status, f"body {self.id} is removed or its world is closed")


class World(WorldCoupling, WorldColliders):
    """A simulation world (``defsim_world``): bodies, their state, and a backend that steps it.

    Args:
        backend: integrator name: "explicit_euler", "symplectic_euler", "velocity_verlet"
            (built in), "newton_cholmod", "newmark", "bdf2", "sundials_ida", "sundials_erk",
            "sundials_kinsol" (modules), or one registered with the C API. Default
            "symplectic_euler".
        gravity: (gx, gy, gz) in m/s^2. Default (0, -9.81, 0).
        num_threads: threads for force and Hessian assembly; 0: OpenMP's default.
        options: options by name, set after creation in order: ``{"core.auto_substep": True,
            "sundials_ida.rtol": 1e-6, "newton_cholmod.projection": "abs"}`` (see
            ``set_option``, ``options()``). A backend's settings (tolerances, iteration limits,
            projection, BDF order) and the core's (auto_substep, substep_safety, the watchdog,
            contact) are options; the keyword arguments tolerance ... substep_safety of
            earlier versions are gone.
        log: optional callable(level, message) that receives the library's log messages.
            Exceptions it raises are printed (as for any cffi callback) and otherwise ignored.

    Arguments left as None take the library's defaults (``defsim_world_def_init``).
    Raises BackendUnavailableError (unknown backend, or its module failed to load),
    InvalidArgumentError (bad gravity or num_threads, an unknown option or a value it refuses).

    Arrays: ``positions``, ``velocities``, ``masses``, ``forces()`` return new numpy arrays
    (copies; the library keeps its own state). Positions, velocities and forces have shape
    (n, 3), vertices in the order the bodies were added. To avoid an allocation per frame, pass
    a preallocated array to ``get_positions(out)`` / ``get_velocities(out)``.

    A world is not thread-safe: use it from one thread at a time. ``close()`` (or a ``with``
    block) frees it at once; otherwise it is freed when garbage-collected.
    """

    #: Bumped when the state arrays move (bodies added or removed, close): StateView's check.
    _layout = 0
    #: Bumped by every call that can change the state: the key of StateView's stress buffers.
    _state_version = 0

    def __init__(self, backend: Optional[str] = None, *, gravity: Any = None,
                 num_threads: Optional[int] = None, log: Optional[LogCallback] = None,
                 options: Optional[Mapping[str, Any]] = None) -> None:
        self._ptr: Any = None
        self._bodies: List[Body] = []
        # What each body was made of, by id: rest positions, tets, triangles, springs (and the
        # springs drawn as lines), for element_stress, defsim.io and the display.
        self._topology: Dict[Tuple[int, int], Topology] = {}
        self._log_cb: Any = None
        self._sdfs: Dict[Tuple[int, int], Any] = {}   # Python SDF trampolines, by collider id
        d = ffi.new("defsim_world_def *")
        lib.defsim_world_def_init(d, ffi.sizeof("defsim_world_def"))
        name_buf = None
        if backend is not None:
            if not isinstance(backend, str):
                raise InvalidArgumentError("backend must be a string")
            name_buf = ffi.new("char[]", backend.encode("utf-8"))
            d.backend = name_buf
        if gravity is not None:
            d.gravity = list(_arrays.triple(gravity, "gravity"))
        if num_threads is not None:
            d.num_threads = _arrays.c_int(num_threads, "num_threads")
        if log is not None:
            self._log_cb = _log_callback(log)
            d.log = self._log_cb
        out = ffi.new("defsim_world **")
        check(lib.defsim_world_create(d, out))
        self._ptr = ffi.gc(out[0], lib.defsim_world_destroy)
        self._backend = ffi.string(d.backend).decode("utf-8")
        self._gravity = (float(d.gravity[0]), float(d.gravity[1]), float(d.gravity[2]))
        del name_buf
        if options is not None:
            try:
                for name, value in dict(options).items():
                    self.set_option(name, value)
            except Exception:
                self.close()
                raise

    @classmethod
    def _adopt(cls, ptr: Any, backend: str, gravity: Tuple[float, float, float],
               bodies: List[Tuple[Tuple[int, int], "Topology"]]) -> "World":
        """Wraps a world that C code created (defsim_scene_build), taking ownership: its bodies
        by id with what they were made of."""
        self = cls.__new__(cls)
        self._log_cb = None
        self._sdfs = {}
        self._ptr = ffi.gc(ptr, lib.defsim_world_destroy)
        self._backend = backend
        self._gravity = gravity
        self._bodies = [Body(self, i, g) for (i, g), _ in bodies]
        self._topology = {bid: topo for bid, topo in bodies}
        return self

    # -- lifetime --------------------------------------------------------------------------

    def close(self) -> None:
        """Destroys the world now. Further calls raise InvalidArgumentError; bodies go stale.
        Closing twice is allowed."""
        if self._ptr is not None:
            ptr, self._ptr = self._ptr, None
            ffi.release(ptr)    # runs defsim_world_destroy while the log callback is alive
        self._bodies = []
        self._layout += 1

    @property
    def closed(self) -> bool:
        return self._ptr is None

    def __enter__(self) -> "World":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        # Destroy before the attributes (the log callback) go.
        try:
            self.close()
        except Exception:
            pass

    def _live(self) -> Any:
        if self._ptr is None:
            raise InvalidArgumentError("the world is closed")
        return self._ptr

    def _check(self, status: int) -> None:
        if status < 0:
            msg = ffi.string(lib.defsim_world_last_error(self._ptr)).decode("utf-8", "replace")
            self._callback_failed(status, msg)   # a Python callback raised: StepError from it
            raise error_from_status(status, msg)

    def _own(self, body: Body) -> Any:
        if not isinstance(body, Body):
            raise InvalidArgumentError("expected a defsim.Body")
        if body._world is not self:
            raise StaleIdError(f"body {body.id} belongs to another world", Status.STALE_ID)
        return body._cid()

    # -- properties ------------------------------------------------------------------------

    @property
    def backend(self) -> str:
        """The backend's name."""
        return self._backend

    @property
    def gravity(self) -> Tuple[float, float, float]:
        """Gravity in m/s^2, as given at creation."""
        return self._gravity

    @property
    def vertex_count(self) -> int:
        """Total vertex count of all live bodies."""
        return int(lib.defsim_world_vertex_count(self._live()))

    @property
    def time(self) -> float:
        """Simulated time in seconds: the sum of h over successful steps."""
        return float(lib.defsim_world_time(self._live()))

    @property
    def bodies(self) -> List[Body]:
        """The live bodies, in the order they were added (a new list)."""
        return list(self._bodies)

    def __iter__(self) -> Iterator[Body]:
        return iter(list(self._bodies))

    def __len__(self) -> int:
        return len(self._bodies)

    @property
    def last_error(self) -> str:
        """Detail of the last failed call on this world, or ""."""
        return ffi.string(lib.defsim_world_last_error(self._live())).decode("utf-8", "replace")

    # -- bodies ----------------------------------------------------------------------------

    def add_body(self, vertices: Union[Mesh, Any], tets: Any = None, springs: Any = None,
                 material: Optional[Material] = None, *, spring_stiffness: Any = None,
                 spring_kinds: Any = None, shear_stiffness: Optional[float] = None,
                 bend_stiffness: Optional[float] = None,
                 vertex_mass: Any = None, initial_positions: Any = None,
                 initial_velocities: Any = None, triangles: Any = None,
                 self_contact: bool = True, collision_group: int = 1,
                 collision_mask: int = 0xFFFFFFFF, friction: float = 0.5,
                 volume_averaging: bool = False,
                 shell: Optional[Shell] = None,
                 contact_thickness: float = 0.0) -> Body:
        """Adds a body; its vertices follow those of the bodies added before it. All arrays are
        copied.

        Args:
            vertices: rest positions (n, 3) in m, or a Mesh (whose tets and springs are used
                unless given here).
            tets: (m, 4) vertex indices (0-based, body-local), or None.
            springs: (s, 2) vertex indices, or None.
            material: a Material; None: the library's default (stable neo-Hookean).
            spring_stiffness: optional (s,) k per spring in N/m (else material.stiffness).
            spring_kinds: optional (s,) SpringKind per spring; a Mesh from ``mesh_cloth`` or
                ``mesh_rope`` brings its own. Stretch springs take material.stiffness, shear and
                bend springs `shear_stiffness` and `bend_stiffness` (N/m; None: also
                material.stiffness). Not together with spring_stiffness.
            shear_stiffness, bend_stiffness: N/m for the springs of those kinds.
            vertex_mass: optional (n,) kg per vertex (else lumped from density plus
                material.vertex_mass).
            initial_positions, initial_velocities: optional (n, 3); default rest and zero.
            triangles: optional (k, 3) surface triangles, used for output and display
                (``defsim.io``, ``_repr_png_``) and, for a body without tets (a cloth), as its
                contact surface with body contact on; a Mesh brings its own; for tets without
                them the boundary is computed.
            self_contact, collision_group, collision_mask, friction: body contact
                (``core.body_contact``; docs/body-contact.md): whether the body collides with
                itself, its group bits, the groups it collides with (bodies A and B collide when
                ``A.group & B.mask`` and ``B.group & A.mask``), its Coulomb coefficient (a pair
                uses the geometric mean).
            contact_thickness: the body's contact thickness t in m (>= 0, default 0;
                ``defsim_body_def.contact_thickness``, docs/body-contact.md "Thickness"):
                contact keeps its surface t / 2 from other bodies (whose half-thickness adds)
                and from colliders, so stacked cloth layers rest t apart.
            volume_averaging: the averaged-nodal-volume tet against volumetric locking of
                nearly incompressible bodies (docs/materials.md), or for quadratic tets the
                mean-dilatation element (docs/elements.md); neo-Hookean and stable neo-Hookean
                only (others raise MaterialError).
            shell: a Shell: the triangles (at least one; no tets) are then also membrane
                elements and bending hinges (docs/shells.md).

        Returns the new Body. Raises InvalidArgumentError (shapes, counts), InvalidMeshError
        (index out of range, degenerate tet, zero-length spring, non-finite coordinate, vertex
        without mass), InvalidMaterialError (bad parameters, tets with the spring model).
        On error the world is unchanged.
        """
        w = self._live()
        if isinstance(vertices, Mesh):
            mesh_springs = springs is None
            if tets is None:
                tets = vertices.tets
            if springs is None:
                springs = vertices.springs
            if triangles is None:
                triangles = vertices.triangles
            if (spring_kinds is None and spring_stiffness is None and mesh_springs and
                    vertices.spring_kinds is not None):
                spring_kinds = vertices.spring_kinds
            vertices = vertices.positions
        rest = _arrays.points(vertices, "vertices")
        n = rest.shape[0]
        quadratic = tets is not None and np.ndim(tets) == 2 and np.shape(tets)[1] == 10
        t = _arrays.indices(tets, "tets", 10 if quadratic else 4)
        s = _arrays.indices(springs, "springs", 2)
        k = None if spring_stiffness is None else _arrays.vector(
            spring_stiffness, "spring_stiffness", s.shape[0])
        if spring_kinds is not None:
            kinds = np.ascontiguousarray(spring_kinds).reshape(-1)
            if kinds.shape[0] != s.shape[0]:
                raise InvalidArgumentError(f"spring_kinds: expected {s.shape[0]} values, got "
                                           f"{kinds.shape[0]}")
            kinds = _arrays.indices(kinds.reshape(-1, 1), "spring_kinds", 1).reshape(-1)
        else:
            kinds = None
            if shear_stiffness is not None or bend_stiffness is not None:
                raise InvalidArgumentError("shear_stiffness / bend_stiffness need spring_kinds "
                                           "(a Mesh from mesh_cloth or mesh_rope has them)")
        tri = _arrays.indices(triangles, "triangles", 3)
        m = None if vertex_mass is None else _arrays.vector(vertex_mass, "vertex_mass", n)
        x0 = None if initial_positions is None else _arrays.points(
            initial_positions, "initial_positions", n)
        v0 = None if initial_velocities is None else _arrays.points(
            initial_velocities, "initial_velocities", n)
        if material is not None and not isinstance(material, Material):
            raise InvalidArgumentError("material must be a defsim.Material")
        d = ffi.new("defsim_body_def *")
        lib.defsim_body_def_init(d, ffi.sizeof("defsim_body_def"))
        # Keep every buffer referenced until the call returns (the library copies them).
        keep = [_arrays.dptr(rest), _arrays.iptr(t), _arrays.iptr(s), _arrays.dptr(k),
                _arrays.dptr(m), _arrays.dptr(x0), _arrays.dptr(v0), _arrays.iptr(kinds)]
        d.rest_positions, d.tets, d.springs = keep[0], keep[1], keep[2]
        if quadratic:
            d.tet_nodes = 10
        d.spring_stiffness, d.vertex_mass = keep[3], keep[4]
        d.initial_positions, d.initial_velocities = keep[5], keep[6]
        if kinds is not None:
            d.spring_kinds = keep[7]
            if shear_stiffness is not None:
                d.shear_stiffness = _arrays.c_double(shear_stiffness, "shear_stiffness")
            if bend_stiffness is not None:
                d.bend_stiffness = _arrays.c_double(bend_stiffness, "bend_stiffness")
        # A body without tets collides through its triangles (a tet body through its boundary).
        keep.append(_arrays.iptr(tri) if tri.size and (not t.size or shell is not None)
                    else ffi.NULL)
        d.triangles = keep[8]
        d.triangle_count = _arrays.c_int(tri.shape[0] if tri.size and (not t.size or
                                                                       shell is not None) else 0,
                                         "triangle count")
        if shell is not None:
            if not isinstance(shell, Shell):
                raise InvalidArgumentError("shell must be a defsim.Shell")
            shell._fill(d)
        d.self_contact = 1 if self_contact else 0
        d.collision_group = _collision_bits(collision_group, "collision_group")
        d.collision_mask = _collision_bits(collision_mask, "collision_mask")
        d.friction = _arrays.c_double(friction, "friction")
        d.contact_thickness = _arrays.c_double(contact_thickness, "contact_thickness")
        d.volume_averaging = 1 if volume_averaging else 0
        d.vertex_count = _arrays.c_int(n, "vertex count")
        d.tet_count = _arrays.c_int(t.shape[0], "tet count")
        d.spring_count = _arrays.c_int(s.shape[0], "spring count")
        if material is not None:
            material._fill(ffi.addressof(d, "material"))
        out = ffi.new("defsim_body_id *")
        self._check(lib.defsim_world_add_body(w, d, out))
        self._layout += 1
        self._state_version += 1
        del keep
        body = Body(self, int(out.index), int(out.generation))
        self._bodies.append(body)
        if not t.size and not tri.size:
            lines = s if kinds is None else s[kinds == SpringKind.STRETCH]
        else:
            lines = s[:0]
        self._topology[body.id] = Topology(rest, t, tri if tri.size or not t.size
                                           else tet_boundary(rest, t), s, lines)
        return body

    def _tet_count(self, body: Body) -> int:
        topo = self._topology.get(body.id)
        return 0 if topo is None else int(topo.tets.shape[0])

    def topology(self, body: Body) -> "Topology":
        """What `body` was made of: rest positions (n, 3), tets (m, 4; (m, 10) quadratic), triangles (k, 3: the
        given surface, or the tets' boundary) and springs (s, 2), body-local indices. Used by
        ``defsim.io`` and the display. Raises StaleIdError for a removed body."""
        self._own(body)
        try:
            return self._topology[body.id]
        except KeyError:
            raise StaleIdError(f"body {body.id} is removed", Status.STALE_ID) from None

    def remove_body(self, body: Body) -> None:
        """Removes a body; the vertices of later bodies move down and its handle goes stale.
        Raises StaleIdError for a removed body or one of another world."""
        self._check(lib.defsim_world_remove_body(self._live(), self._own(body)))
        self._layout += 1
        self._state_version += 1
        self._bodies = [b for b in self._bodies if b != body]
        self._topology.pop(body.id, None)

    def _vertex_list(self, body: Body, vertices: Any) -> np.ndarray:
        a = np.asarray(vertices)
        if a.dtype == np.bool_:
            n = body.vertex_count
            if a.shape != (n,):
                raise InvalidArgumentError(f"vertices: a boolean mask needs shape ({n},), got "
                                           f"{a.shape}")
            return np.flatnonzero(a).astype(np.int32)
        return _arrays.indices(a.reshape(-1) if a.ndim == 0 else a, "vertices", 1).reshape(-1)

    def pin(self, body: Body, vertices: Any) -> None:
        """Pins vertices of a body where they are now: their velocity becomes zero and they do
        not move until unpinned. `vertices`: body-local indices (an int, a sequence, an int
        array) or a boolean mask over the body's vertices. Pinning a pinned vertex is allowed.
        Raises InvalidArgumentError (index out of range), StaleIdError."""
        cid = self._own(body)
        v = self._vertex_list(body, vertices)
        self._state_version += 1   # pinned vertices' velocities become zero
        self._check(lib.defsim_body_pin(self._live(), cid, _arrays.iptr(v), v.size))

    def unpin(self, body: Body, vertices: Any) -> None:
        """Unpins vertices (same arguments as pin); unpinning a free vertex is allowed."""
        cid = self._own(body)
        v = self._vertex_list(body, vertices)
        self._check(lib.defsim_body_unpin(self._live(), cid, _arrays.iptr(v), v.size))

    def set_collision(self, body: Body, self_contact: bool = True, group: int = 1,
                      mask: int = 0xFFFFFFFF) -> None:
        """Changes a body's collision filter (as the add_body arguments of the same names);
        takes effect at the next step. Raises InvalidArgumentError, StaleIdError."""
        cid = self._own(body)
        self._check(lib.defsim_body_set_collision(
            self._live(), cid, 1 if self_contact else 0, _collision_bits(group, "group"),
            _collision_bits(mask, "mask")))

    # -- simulation ------------------------------------------------------------------------

    def record(self, interval: int = 0, max_bytes: Optional[int] = None) -> "Tape":
        """Begins recording the steps that follow, for gradients (docs/gradients.md): returns a
        Tape whose ``backward(dL_dx=..., dL_dv=...)`` gives the gradients of a loss of the
        recorded states by name. interval: store every interval-th state and recompute the
        others in the backward pass (0: every state while they fit in max_bytes, default
        256 MiB, then thinned). Raises UnsupportedError (the backend or a term of the scene
        cannot be differentiated: the message names it), InvalidArgumentError (a recording
        is under way)."""
        from ._tape import Tape
        return Tape(self, interval, max_bytes)

    def step(self, h: float, steps: int = 1, *,
             progress: Union[None, bool, Callable[[int, int], Any], Any] = None) -> None:
        """Advances the world by `steps` steps of h seconds each with its backend.

        progress: None (default) reports nothing; True shows a tqdm bar (the extra
            ``pip install 'defsim-fem[progress]'``; without tqdm a ModuleNotFoundError that
            says so, before any step); a tqdm bar you made is advanced by one per step; a
            callable ``fn(done, total)`` is called after every step (return value ignored; an
            exception it raises stops the loop after that step and propagates).

        Raises InvalidArgumentError (h not finite or <= 0), UnstableError (the state became
        non-finite), NotConvergedError (implicit backends). A failed step leaves positions,
        velocities and time exactly as before it; earlier steps of the same call stay done.
        """
        w = self._live()
        hh = _arrays.c_double(h, "h")
        n = _arrays.c_int(steps, "steps")
        if n < 0:
            raise InvalidArgumentError("steps must be >= 0")
        self._step_loop(n, lambda: lib.defsim_world_step(w, hh), progress)

    def _step_loop(self, n: int, one: Callable[[], int], progress: Any) -> None:
        report, close = _progress(progress, n)
        try:
            for i in range(n):
                self._state_version += 1
                st = one()
                if st < 0:
                    self._check(st)
                if report is not None:
                    report(i + 1, n)
        finally:
            if close is not None:
                close()

    def view(self, h: float, **settings: Any) -> Any:
        """Opens the live viewer on this world (``defsim.view``: play, step, reset, orbit,
        colours, drag a vertex) and returns its ``defsim.ViewResult`` when the window closes."""
        from ._view import view
        return view(self, h, **settings)

    def _repr_png_(self) -> Optional[bytes]:
        """A rendered PNG of the current state for Jupyter (``defsim.display.render_png``:
        body colours, pins, colliders), or None (Jupyter then shows the text repr) when no
        renderer (libdefsim_render or PyVista) is available."""
        from .display import png_or_none
        return png_or_none(self)

    def _repr_html_(self) -> Optional[str]:
        """The picture of ``_repr_png_`` inline in an HTML figure with a caption (time, bodies,
        vertices, pins, colliders), or None as for ``_repr_png_``."""
        from .display import html_or_none
        return html_or_none(self)

    def get_positions(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Positions (n, 3) in m, written into `out` (a C-contiguous float64 array of n*3
        values) if given, else into a new array. Returns the array."""
        return self._get(lib.defsim_world_get_positions, out, 3, "out")

    def get_velocities(self, out: Optional[np.ndarray] = None) -> np.ndarray:
        """Velocities (n, 3) in m/s; same rules as get_positions."""
        return self._get(lib.defsim_world_get_velocities, out, 3, "out")

    def _get(self, fn: Any, out: Optional[np.ndarray], width: int, name: str) -> np.ndarray:
        w = self._live()
        n = int(lib.defsim_world_vertex_count(w))
        if out is None:
            out = np.empty((n, width) if width > 1 else (n,))
        elif (not isinstance(out, np.ndarray) or out.dtype != np.float64
              or not out.flags.c_contiguous or not out.flags.writeable
              or out.size != width * n):
            raise InvalidArgumentError(
                f"{name}: needs a writable C-contiguous float64 array of {width * n} values")
        if n > 0:
            self._check(fn(w, _arrays.dptr(out), n))
        return out

    def state_view(self) -> "StateView":
        """Zero-copy, read-only numpy views of the positions and velocities, which see every
        step as it happens, valid until the bodies change (``add_body``, ``remove_body``) or
        the world is closed: see ``defsim.StateView``. ``positions`` and ``velocities`` stay
        copies."""
        from ._state_view import StateView
        return StateView(self)

    @property
    def positions(self) -> np.ndarray:
        """A copy of the positions, (n, 3), m. Assigning sets them (``set_state``)."""
        return self.get_positions()

    @positions.setter
    def positions(self, value: Any) -> None:
        self.set_state(positions=value)

    @property
    def velocities(self) -> np.ndarray:
        """A copy of the velocities, (n, 3), m/s. Assigning sets them (``set_state``)."""
        return self.get_velocities()

    @velocities.setter
    def velocities(self, value: Any) -> None:
        self.set_state(velocities=value)

    @property
    def masses(self) -> np.ndarray:
        """A copy of the lumped vertex masses, (n,), kg."""
        return self._get(lib.defsim_world_get_masses, None, 1, "out")

    def set_state(self, positions: Any = None, velocities: Any = None) -> None:
        """Sets positions and/or velocities ((n, 3) each; None: unchanged). Pinned vertices
        take the given positions as their new targets and zero velocity. Raises
        InvalidArgumentError (shape, non-finite value); on error nothing changes."""
        w = self._live()
        n = int(lib.defsim_world_vertex_count(w))
        x = None if positions is None else _arrays.points(positions, "positions", n)
        v = None if velocities is None else _arrays.points(velocities, "velocities", n)
        self._state_version += 1
        self._check(lib.defsim_world_set_state(w, _arrays.dptr(x), _arrays.dptr(v)))

    def stable_step(self) -> Tuple[float, float]:
        """(h, omega_max): the largest stable step (s) of the world's backend from the current
        state, and the highest angular frequency (rad/s) of the linearised system
        (``defsim_world_stable_step``). h is inf for implicit backends, 0 for explicit Euler
        without damping."""
        h = ffi.new("double *")
        om = ffi.new("double *")
        self._check(lib.defsim_world_stable_step(self._live(), h, om))
        return float(h[0]), float(om[0])

    def energy(self) -> Energy:
        """Kinetic, elastic (relative to rest), gravitational and total energy in J."""
        e = ffi.new("defsim_energy *")
        self._check(lib.defsim_world_energy(self._live(), e))
        return Energy(float(e.kinetic), float(e.elastic), float(e.gravitational), float(e.total))

    def forces(self, positions: Any = None) -> np.ndarray:
        """Elastic forces -dE/dx (N) at `positions` ((n, 3); None: the current ones), as a new
        (n, 3) array. No gravity, damping or pinning is applied."""
        w = self._live()
        n = int(lib.defsim_world_vertex_count(w))
        x = None if positions is None else _arrays.points(positions, "positions", n)
        f = np.zeros((n, 3))
        if n > 0:
            self._check(lib.defsim_world_forces(w, _arrays.dptr(x), _arrays.dptr(f)))
        return f

    def stats(self) -> Stats:
        """The world's counters and timings."""
        s = ffi.new("defsim_stats *")
        s.size = ffi.sizeof("defsim_stats")
        self._check(lib.defsim_world_stats(self._live(), s))
        values = {f.name: getattr(s, f.name) for f in dataclasses.fields(Stats)
                  if f.name != "counters"}
        values["passes"] = Pass(int(s.passes))
        for k, v in values.items():
            if k != "passes":
                values[k] = float(v) if isinstance(v, float) else int(v)
        w = self._live()
        name = ffi.new("const char **")
        value = ffi.new("double *")
        counters = {}
        for i in range(int(lib.defsim_world_stat_count(w))):
            self._check(lib.defsim_world_stat_info(w, i, name, value))
            key = ffi.string(name[0]).decode("utf-8")
            # "<backend>.<counter>"; the stats' own fields have no dot, and contact's
            # ("contact.*", docs/contact.md) and the term kinds' ("collider.linearisations")
            # are the core's: read them with stat()
            if key.startswith(self._backend + "."):
                counters[key] = float(value[0])
        return Stats(counters=counters, **values)

    def reset_stats(self) -> None:
        """Zeroes the counters and timings (not reordered_tets, threads, passes), the backend's
        counters included."""
        lib.defsim_world_reset_stats(self._live())

    # -- options and statistics by name ----------------------------------------------------

    def set_option(self, name: str, value: Union[str, bool, int, float]) -> None:
        """Sets an option by name: ``"core.simd"``, ``"core.auto_substep"``,
        ``"core.substep_safety"``, or ``"<backend>.<option>"`` of this world's backend. A string
        is parsed by the library ("1e-6", "true", "clamp"); a bool sets 0 or 1; a number sets
        the value (for a choice, its index). Changing a backend option re-initialises the
        backend before the next step. Raises InvalidArgumentError (unknown name, another
        backend's option, bad value: the message lists what is valid); the world is then
        unchanged."""
        w = self._live()
        if not isinstance(name, str):
            raise InvalidArgumentError("option name must be a string")
        cname = name.encode("utf-8")
        if isinstance(value, str):
            self._check(lib.defsim_world_set_option(w, cname, value.encode("utf-8")))
        elif isinstance(value, (bool, int, float, np.bool_, np.integer, np.floating)):
            self._check(lib.defsim_world_set_option_number(w, cname, float(value)))
        else:
            raise InvalidArgumentError(f"option {name}: value must be a string, bool or number, "
                                       f"not {type(value).__name__}")

    def _option_infos(self) -> List[Any]:
        w = self._live()
        infos = []
        for i in range(int(lib.defsim_world_option_count(w))):
            info = ffi.new("defsim_option_info *")
            info.size = ffi.sizeof("defsim_option_info")
            self._check(lib.defsim_world_option_info(w, i, info))
            infos.append(info)
        return infos

    @staticmethod
    def _typed(info: Any) -> Union[str, bool, int, float]:
        v = float(info.value)
        if info.type == lib.DEFSIM_OPTION_INT:
            return int(v)
        if info.type == lib.DEFSIM_OPTION_BOOL:
            return v != 0.0
        if info.type == lib.DEFSIM_OPTION_CHOICE:
            return ffi.string(info.choices).decode("utf-8").split("|")[int(v)]
        return v

    def option(self, name: str) -> Union[str, bool, int, float]:
        """The current value of an option: a float (REAL), int (INT), bool (BOOL) or the
        chosen name (CHOICE). Raises InvalidArgumentError for an unknown name."""
        value = ffi.new("double *")   # the library explains an unknown name
        self._check(lib.defsim_world_get_option(self._live(), str(name).encode("utf-8"), value))
        return next(self._typed(i) for i in self._option_infos()
                    if ffi.string(i.name).decode("utf-8") == name)

    def options(self) -> Dict[str, Union[str, bool, int, float]]:
        """Every option of the world (the core's, then its backend's) and its value, typed as
        ``option()`` returns it."""
        return {ffi.string(i.name).decode("utf-8"): self._typed(i) for i in self._option_infos()}

    def stat(self, name: str) -> float:
        """A statistic by name: a field of ``Stats`` ("steps", "force_evals", ...) or a
        counter of the backend ("sundials_ida.internal_steps", "newton_cholmod.newton_iterations"). Raises InvalidArgumentError
        for an unknown name."""
        value = ffi.new("double *")
        self._check(lib.defsim_world_stat(self._live(), str(name).encode("utf-8"), value))
        return float(value[0])

    # -- checkpoints (docs/checkpoints.md) -------------------------------------------------

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes a checkpoint of the world to `path`, atomically (a temporary file in the same
        folder, flushed, then renamed over `path`). ``World.load(path)`` continues the run bit
        for bit. Not saved: the log and force callbacks (install the force callback again).
        Raises FileError (cannot write; the old file at `path` is kept)."""
        self._check(lib.defsim_world_save(self._live(), os.fsencode(path)))

    def to_bytes(self) -> bytes:
        """The checkpoint as bytes (what ``save`` writes)."""
        data = ffi.new("void **")
        size = ffi.new("size_t *")
        self._check(lib.defsim_world_save_buffer(self._live(), data, size))
        try:
            return bytes(ffi.buffer(data[0], size[0]))
        finally:
            lib.defsim_buffer_free(data[0])

    @classmethod
    def load(cls, path: Union[str, "os.PathLike[str]"], *,
             log: Optional[LogCallback] = None) -> "World":
        """A new world from a checkpoint file (see ``save``); `log` as for ``World()``. Bodies
        are the saved world's live bodies in order (``bodies``), with new handles. Raises
        FileError (unreadable, truncated, corrupted, not a checkpoint, newer format),
        BackendUnavailableError."""
        with open(os.fsencode(path), "rb") as f:
            return cls.from_bytes(f.read(), log=log)

    @classmethod
    def from_bytes(cls, data: bytes, *, log: Optional[LogCallback] = None) -> "World":
        """A new world from checkpoint bytes (``to_bytes``); as ``load``."""
        self = cls.__new__(cls)
        self._adopt_checkpoint(bytes(data), log)
        return self

    def __getstate__(self) -> Dict[str, Any]:
        """Pickling saves the checkpoint; the log and force callbacks are not pickled."""
        return {"checkpoint": self.to_bytes()}

    def __setstate__(self, state: Mapping[str, Any]) -> None:
        self._adopt_checkpoint(bytes(state["checkpoint"]), None)

    def _adopt_checkpoint(self, data: bytes, log: Optional[LogCallback]) -> None:
        """Builds this (new, empty) object's world from checkpoint bytes."""
        self._ptr = None
        self._bodies = []
        self._topology = {}
        self._sdfs = {}
        self._log_cb = None
        if log is not None:
            self._log_cb = _log_callback(log)
        out = ffi.new("defsim_world **")
        buf = ffi.from_buffer(data)
        check(lib.defsim_world_load_buffer(buf, len(data), self._log_cb or ffi.NULL, ffi.NULL,
                                           out))
        self._ptr = ffi.gc(out[0], lib.defsim_world_destroy)
        # What the constructor knew: the backend, gravity and each body's topology, from the
        # file (the library checked it whole). WRLD comes first; a BODY chunk holds id,
        # generation, nv, nt, ns, (format 8 on) the indices per tet, model, 7 material numbers,
        # then rest positions, masses, tets, springs, stiffnesses, pin flags, (format 4 on) the
        # triangles (docs/checkpoints.md).
        at = 16
        version = struct.unpack_from("<I", data, 8)[0]
        topologies = []
        while at + 12 <= len(data):
            tag, length = data[at:at + 4], struct.unpack_from("<Q", data, at + 4)[0]
            payload = data[at + 12:at + 12 + length]
            if tag == b"WRLD":
                n = struct.unpack_from("<I", payload, 0)[0]
                self._backend = payload[4:4 + n].decode("utf-8")
                self._gravity = struct.unpack_from("<3d", payload, 4 + n)
            elif tag == b"BODY":
                nv, nt, ns = struct.unpack_from("<3i", payload, 8)
                # format 8 on: the indices per tet after the counts
                tn = struct.unpack_from("<i", payload, 20)[0] if version >= 8 else 4
                o = (28 if version >= 8 else 24) + 7 * 8
                rest = np.frombuffer(payload, "<f8", 3 * nv, o).reshape(nv, 3).copy()
                o += 8 * 3 * nv + 8 * nv
                tets = np.frombuffer(payload, "<i4", tn * nt, o).reshape(nt, tn).copy()
                o += 4 * tn * nt
                springs = np.frombuffer(payload, "<i4", 2 * ns, o).reshape(ns, 2).copy()
                tri = tet_boundary(rest, tets) if nt else np.zeros((0, 3), np.int32)
                if not nt and version >= 4:
                    # format 4 on: after the spring stiffnesses and pin flags, the given
                    # triangles' count, the contact edges' count, then the triangles (a
                    # cloth's or a shell's surface)
                    o += 8 * ns + 8 * ns + nv
                    ntri = struct.unpack_from("<i", payload, o)[0]
                    tri = np.frombuffer(payload, "<i4", 3 * ntri, o + 8).reshape(ntri, 3).copy()
                lines = springs if not nt and not tri.size else springs[:0]
                topologies.append(Topology(rest, tets, tri, springs, lines))
            at += 16 + length
        w = self._ptr
        cid = ffi.new("defsim_body_id *")
        for i in range(int(lib.defsim_world_body_count(w))):
            check(lib.defsim_world_body_at(w, i, cid))
            body = Body(self, int(cid.index), int(cid.generation))
            self._bodies.append(body)
            self._topology[body.id] = topologies[i]

    def to_scene(self, path: Optional[Union[str, "os.PathLike[str]"]] = None, *,
                 h: Optional[float] = None, duration: Optional[float] = None) -> Dict[str, Any]:
        """The world as a scene (``defsim_scene_export``): a dict of the scene JSON that
        ``defsim.io.load_scene`` (and ``defsim run``) read back into a world that steps to the
        same bits from the current state. It holds the backend, gravity, threads and the options
        that differ from their defaults, every body as the library holds it (an "inline" mesh,
        masses, spring stiffnesses, material, pins, held forces, collision filter, the current
        positions and velocities as the initial state), attachments and colliders; a world made
        by a scene (``load_scene(...).world``) adds the scene's body names, drives and keyed
        paths. With `path`, the JSON is also written there.

        `h` and `duration` (s) are the run's, which a scene file needs and a world does not
        hold: default the scene's for a scene's world, else 1e-3 s and 1 s.

        Raises UnsupportedError for what a scene cannot hold: a force callback or an SDF
        collider (host functions), driven-pin targets or a collider pose set for the next step
        (export before setting them or after the step), a scene's keyed paths at t != 0. From
        a world that has stepped, the file starts from its state with the backend's history
        (multistep, adaptive) and contact's carried state afresh: close to, not the bits of,
        the continued run (``save`` continues bit for bit)."""
        import json
        from . import io
        lib = io._scene_lib()
        if getattr(self, "_force_callback", None) is not None:
            raise UnsupportedError("to_scene: the world has a force callback (a Python function), "
                                   "which a scene file cannot hold; clear it first "
                                   "(set_force_callback(None))", Status.UNSUPPORTED)
        scene = getattr(self, "_scene", None)
        hh = -1.0 if h is None else _arrays.c_double(h, "h")
        dd = -1.0 if duration is None else _arrays.c_double(duration, "duration")
        if scene is None:
            hh = 1e-3 if h is None else hh
            dd = 1.0 if duration is None else dd
        text = ffi.new("char **")
        err = ffi.new("char[]", 4096)
        st = lib.defsim_scene_export(self._live(), scene._ptr if scene is not None else ffi.NULL,
                                     hh, dd, text, ffi.NULL, err, 4096)
        if st < 0:
            raise error_from_status(st, ffi.string(err).decode("utf-8", "replace"))
        try:
            data = ffi.string(text[0]).decode("utf-8")
        finally:
            lib.defsim_scene_string_free(text[0])
        if path is not None:
            tmp = os.fspath(path) + ".tmp"
            with open(tmp, "w", encoding="utf-8") as f:
                f.write(data)
            os.replace(tmp, path)
        return json.loads(data)

    def attachments(self) -> List[Any]:
        """The live attachments, in the order the world holds them (a new list of handles)."""
        w = self._live()
        cid = ffi.new("defsim_attachment_id *")
        out = []
        for i in range(int(lib.defsim_world_attachment_count(w))):
            self._check(lib.defsim_world_attachment_at(w, i, cid))
            out.append(Attachment(self, int(cid.index), int(cid.generation)))
        return out

    def __repr__(self) -> str:
        if self._ptr is None:
            return "<defsim.World closed>"
        return (f"<defsim.World backend={self._backend!r} bodies={len(self._bodies)} "
                f"vertices={self.vertex_count} t={self.time:g}>")


class Topology(NamedTuple):
    """What a body was made of (``World.topology``): body-local indices."""

    rest: np.ndarray        #: (n, 3) rest positions, m
    tets: np.ndarray        #: (m, 4)
    triangles: np.ndarray   #: (k, 3): given surface triangles, or the tets' boundary
    springs: np.ndarray     #: (s, 2)
    lines: np.ndarray       #: (l, 2): springs drawn and written as lines (a body without
                            #: tets or triangles: its stretch springs)


def tet_boundary(rest: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Faces used by exactly one tet, oriented outward (away from the tet's fourth vertex); for
    quadratic tets ((m, 10)) each face as 4 triangles through its mid-edge nodes, as the library
    makes them (corner, corner, corner, then the middle one)."""
    if tets.shape[1] == 10:
        corners = tet_boundary(rest, tets[:, :4])
        mid = {}
        for k, (a, b) in enumerate([(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]):
            for u, w, m in zip(tets[:, a], tets[:, b], tets[:, 4 + k]):
                mid[(min(u, w), max(u, w))] = m
        out = []
        for v0, v1, v2 in corners:
            m01 = mid[(min(v0, v1), max(v0, v1))]
            m12 = mid[(min(v1, v2), max(v1, v2))]
            m20 = mid[(min(v2, v0), max(v2, v0))]
            out += [(v0, m01, m20), (m01, v1, m12), (m20, m12, v2), (m01, m12, m20)]
        return np.asarray(out, dtype=np.int32).reshape(-1, 3)
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]],
                            tets[:, [0, 1, 2]]])
    opposite = np.concatenate([tets[:, 0], tets[:, 1], tets[:, 2], tets[:, 3]])
    _, inverse, counts = np.unique(np.sort(faces, axis=1), axis=0, return_inverse=True,
                                   return_counts=True)
    once = counts[inverse.reshape(-1)] == 1
    f, o = faces[once], opposite[once]
    a, b, c = rest[f[:, 0]], rest[f[:, 1]], rest[f[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), a - rest[o]) < 0
    f[inward] = f[inward][:, [0, 2, 1]]
    return np.ascontiguousarray(f, dtype=np.int32)


def _progress(progress: Any, total: int) -> Tuple[Optional[Callable[[int, int], Any]],
                                                  Optional[Callable[[], Any]]]:
    """(report(done, total), close) for World.step's progress argument."""
    if progress is None or progress is False:
        return None, None
    if progress is True:
        try:
            from tqdm.auto import tqdm   # the optional extra [progress]
        except ImportError as exc:
            raise ModuleNotFoundError(
                "World.step(progress=True) needs tqdm, the optional extra [progress]: "
                "pip install 'defsim-fem[progress]' (or pip install tqdm); or pass a "
                "callable(done, total) as progress", name="tqdm") from exc
        bar = tqdm(total=total, unit="step")
        return (lambda done, n: bar.update(1)), bar.close
    if hasattr(progress, "update"):
        return (lambda done, n: progress.update(1)), None
    if callable(progress):
        return progress, None
    raise InvalidArgumentError("progress must be None, True, a tqdm bar or callable(done, total)")
