# SPDX-License-Identifier: MIT
"""The live viewer on a World: ``defsim.view(world, h=...)`` (or ``world.view(h=...)``) opens the
window of ``defsim view`` (libdefsim_view, ``defsim_view_world``) on the world and returns when
it is closed. Play and pause (space), single step (n), reset (r), orbit (left drag), zoom
(wheel), colours (c, or 1-4: body, stress, displacement, speed), and drag a vertex with the
right mouse button (a temporary attachment, removed on release). The step time and the
watchdog's diagnostics are shown over the picture. Needs libdefsim_view (built with GLFW) and a
display (X11, Wayland or Xvfb) with OpenGL 3.3."""
from __future__ import annotations

import dataclasses
import os
from typing import Any, List, Optional, Tuple

import numpy as np

from ._errors import InvalidArgumentError, error_from_status
from ._native import ffi
from .display import loads, optional_lib

__all__ = ["view", "ViewResult", "view_available"]

_COLORS = {"body": 0, "stress": 1, "displacement": 2, "speed": 3}


def _view_lib() -> Any:
    return optional_lib("view", "the viewer needs libdefsim_view (the tools built with GLFW, "
                                "libglfw3-dev)")


def view_available() -> bool:
    """True when libdefsim_view can be loaded (a display is still needed to open a window)."""
    return loads("view")


@dataclasses.dataclass(frozen=True)
class ViewResult:
    """How a viewer session went (``defsim_view_result``)."""

    steps: int                       #: successful steps the viewer took
    last_failure: int                #: status of the last failed step (0: none)
    drag_vertex: Optional[int]       #: world index of the last vertex dragged, or None
    drag_start: Tuple[float, float, float]    #: its position when grabbed (m)
    drag_target: Tuple[float, float, float]   #: the spring's target when last moved (m)
    drag_end: Tuple[float, float, float]      #: its position when released (m)
    expectations: int                #: the script's ``expect`` lines that ran
    expectations_failed: int         #: and those that failed


def view(world: Any, h: float, steps_per_frame: int = 1, width: int = 960, height: int = 600,
         color: str = "body", paused: bool = False, script: Optional[str] = None,
         show_timing: bool = True, drag_stiffness: float = 0.0, supersample: int = 1,
         title: Optional[str] = None) -> ViewResult:
    """Opens the viewer on `world`, stepping it by `h` seconds (`steps_per_frame` steps per
    drawn frame while playing), and blocks until the window is closed, or until `script` (an
    input script, tools/view/README.md) ends. The world keeps the state the session left (reset
    restores the positions and velocities it had when the call began; the time keeps counting);
    the attachment of a drag is removed. `color` is "body", "stress", "displacement" or "speed".

    Raises defsim.Error with status BACKEND_UNAVAILABLE when libdefsim_view is missing or there
    is no display with OpenGL 3.3, InvalidArgumentError for a bad setting or script, FileError
    for a script that cannot be read or a screenshot that cannot be written."""
    lib = _view_lib()
    if color not in _COLORS:
        raise InvalidArgumentError(f"color must be one of {', '.join(_COLORS)}, not {color!r}")
    # The bodies in vertex order, as defsim_world_body_at lists them.
    bodies = sorted(world.bodies, key=lambda b: b.vertex_offset)
    parts = ffi.new("defsim_view_body[]", max(1, len(bodies)))
    keep: List[Any] = []

    def arr(a: np.ndarray) -> Any:
        a = np.ascontiguousarray(a, dtype=np.int32)
        keep.append(a)
        return ffi.from_buffer("int32_t[]", a) if a.size else ffi.NULL

    for i, b in enumerate(bodies):
        topo = world.topology(b)
        parts[i].triangles = arr(topo.triangles)
        parts[i].triangle_count = topo.triangles.shape[0]
        parts[i].lines = arr(topo.lines)
        parts[i].line_count = topo.lines.shape[0]
        # quadratic tets: drawn by their boundary's sub-triangles, without stress colours
        quadratic = topo.tets.shape[1] == 10
        parts[i].tets = arr(topo.tets[:0, :4] if quadratic else topo.tets)
        parts[i].tet_count = 0 if quadratic else topo.tets.shape[0]
        parts[i].color = [-1.0, 0.0, 0.0]
    d = ffi.new("defsim_view_def *")
    lib.defsim_view_def_init(d, ffi.sizeof("defsim_view_def"))
    d.h = float(h)
    d.steps_per_frame = int(steps_per_frame)
    d.width, d.height = int(width), int(height)
    d.supersample = int(supersample)
    d.color = _COLORS[color]
    d.paused = 1 if paused else 0
    d.show_timing = 1 if show_timing else 0
    d.drag_stiffness = float(drag_stiffness)
    d.gravity = list(world.gravity)
    strings = []
    if script is not None:
        strings.append(ffi.new("char[]", os.fsencode(script)))
        d.script = strings[-1]
    if title is not None:
        strings.append(ffi.new("char[]", title.encode("utf-8")))
        d.title = strings[-1]
    r = ffi.new("defsim_view_result *")
    r.size = ffi.sizeof("defsim_view_result")
    err = ffi.new("char[]", 1024)
    st = lib.defsim_view_world(world._live(), parts, len(bodies), d, r, err, 1024)
    if st < 0:
        raise error_from_status(st, ffi.string(err).decode("utf-8", "replace"))
    return ViewResult(
        steps=int(r.steps), last_failure=int(r.last_failure),
        drag_vertex=int(r.drag_vertex) if r.drag_vertex >= 0 else None,
        drag_start=tuple(float(v) for v in r.drag_start),
        drag_target=tuple(float(v) for v in r.drag_target),
        drag_end=tuple(float(v) for v in r.drag_end),
        expectations=int(r.expectations), expectations_failed=int(r.expectations_failed))
