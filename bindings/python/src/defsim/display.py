# SPDX-License-Identifier: MIT
"""Pictures of a world: ``render_png(world)`` renders the current state with the OSMesa renderer
of ``defsim run`` (libdefsim_render, off-screen: no display needed), and ``World._repr_png_``
shows it in Jupyter. The renderer is optional: wheels leave it out, and without it
``render_png`` raises and Jupyter falls back to the text repr."""
from __future__ import annotations

import os
import tempfile
from typing import Any, List, Optional

import numpy as np

from ._errors import Error, Status, error_from_status
from ._native import ffi, open_extra

__all__ = ["render_png", "available"]


def optional_lib(name: str, needs: str) -> Any:
    """open_extra(name), or defsim.Error with status BACKEND_UNAVAILABLE naming what `needs`
    (the optional libraries of the tools: "render" here, "view" for defsim.view)."""
    try:
        return open_extra(name)
    except OSError as exc:
        raise Error(f"{needs}: {exc}", Status.BACKEND_UNAVAILABLE) from exc


def loads(name: str) -> bool:
    """True when the optional library `name` can be loaded."""
    try:
        optional_lib(name, name)
        return True
    except Error:
        return False


def _render_lib() -> Any:
    return optional_lib("render", "rendering needs libdefsim_render (the tools built with "
                                  "OSMesa and libpng)")


def available() -> bool:
    """True when libdefsim_render can be loaded."""
    return loads("render")


def render_png(world: Any, width: int = 640, height: int = 400) -> bytes:
    """The world's current state as PNG bytes (width x height, RGB): each body's surface
    triangles (cloth smooth, solids flat) and line springs as tubes, in ``defsim run``'s colours,
    with its automatic camera and ground grid ("up" against gravity).

    Raises defsim.Error with status BACKEND_UNAVAILABLE when libdefsim_render is missing or no
    OSMesa context can be made, InvalidArgumentError for an empty world or a bad size."""
    lib = _render_lib()
    x = world.positions
    parts = ffi.new("defsim_render_part[]", max(1, len(world.bodies)))
    keep: List[Any] = []
    for i, b in enumerate(world.bodies):
        topo = world.topology(b)
        off = b.vertex_offset
        tris = np.ascontiguousarray(topo.triangles + off, dtype=np.int32)
        lines = np.ascontiguousarray(topo.lines + off, dtype=np.int32)
        keep += [tris, lines]
        parts[i].triangles = ffi.from_buffer("int32_t[]", tris) if tris.size else ffi.NULL
        parts[i].triangle_count = tris.shape[0]
        parts[i].lines = ffi.from_buffer("int32_t[]", lines) if lines.size else ffi.NULL
        parts[i].line_count = lines.shape[0]
        parts[i].color = [-1.0, 0.0, 0.0]
        parts[i].smooth = 1 if topo.tets.size == 0 else 0
    err = ffi.new("char[]", 1024)
    fd, path = tempfile.mkstemp(suffix=".png", prefix="defsim_")
    os.close(fd)
    try:
        xs = np.ascontiguousarray(x, dtype=np.float64)
        st = lib.defsim_render_png(path.encode("utf-8"), int(width), int(height), xs.shape[0],
                                   ffi.from_buffer("double[]", xs), parts, len(world.bodies),
                                   list(world.gravity), err, 1024)
        if st < 0:
            raise error_from_status(st, ffi.string(err).decode("utf-8", "replace"))
        with open(path, "rb") as f:
            return f.read()
    finally:
        os.unlink(path)


def png_or_none(world: Any) -> Optional[bytes]:
    """render_png, or None when the renderer is unavailable or the world is empty or closed
    (what IPython expects of ``_repr_png_``)."""
    if getattr(world, "closed", True) or not world.bodies or not available():
        return None
    try:
        return render_png(world)
    except Error:
        return None
