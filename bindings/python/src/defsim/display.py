# SPDX-License-Identifier: MIT
"""Pictures of a world, for Jupyter and for files.

``render_png(world, color=..., pins=..., contact_forces=...)`` draws the current state as
``defsim run --render`` draws a frame: each body's surface coloured by body, von Mises stress,
displacement or speed (with its colour bar), red markers on pinned vertices, the colliders at
their poses (the first plane carries the ground grid) and, on request, the contact forces as
arrows. Two renderers do it:

* ``"osmesa"``: libdefsim_render, the OSMesa renderer of ``defsim run`` itself
  (``defsim_render_world_png``: the same code, off-screen, no display needed). Built with the
  tools when OSMesa and libpng are found; wheels leave it out.
* ``"pyvista"``: PyVista (an optional dependency, ``pip install 'defsim-fem[display]'``), for
  installs without libdefsim_render. It draws the frame that ``defsim.io.write_vtu`` writes
  (the same arrays, by the same C code) with VTK, off-screen.

``backend="auto"`` (the default) takes the first that is available. ``World._repr_png_`` and
``World._repr_html_`` show the world in Jupyter with the defaults (body colours, pins,
colliders); ``Picture(world, color="stress")`` is a picture with other settings that Jupyter
shows as PNG or HTML (the picture, its colour scale and what is drawn).
"""
from __future__ import annotations

import base64
import html
import os
import tempfile
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np

from ._errors import Error, InvalidArgumentError, Status, error_from_status
from ._native import ffi, open_extra

__all__ = ["render_png", "available", "backends", "Picture", "COLORS"]

#: The colour modes, as ``defsim run --color`` names them.
COLORS = ("body", "stress", "displacement", "speed")
_UNITS = {"stress": "von Mises stress (Pa)", "displacement": "displacement (m)",
          "speed": "speed (m/s)"}


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
    return optional_lib("render", "rendering with OSMesa needs libdefsim_render (the tools built "
                                  "with OSMesa and libpng)")


def _has_pyvista() -> bool:
    try:
        import pyvista  # noqa: F401
    except ImportError:
        return False
    return True


def backends() -> List[str]:
    """The renderers this install has, in the order ``backend="auto"`` tries them."""
    out = []
    try:
        _render_lib()
        out.append("osmesa")
    except Error:
        pass
    if _has_pyvista():
        out.append("pyvista")
    return out


def available() -> bool:
    """True when some renderer is available (libdefsim_render or PyVista)."""
    return bool(backends())


def _check(color: str, width: int, height: int, backend: str) -> None:
    if color not in COLORS:
        raise InvalidArgumentError(f"color {color!r}: one of {', '.join(COLORS)}")
    if backend not in ("auto", "osmesa", "pyvista"):
        raise InvalidArgumentError(f"backend {backend!r}: auto, osmesa or pyvista")
    for name, v in (("width", width), ("height", height)):
        if not isinstance(v, (int, np.integer)) or not 16 <= int(v) <= 8192:
            raise InvalidArgumentError(f"{name} = {v!r}: a whole number of pixels in 16..8192")


def render_png(world: Any, width: int = 640, height: int = 400, *, color: str = "body",
               pins: bool = True, colliders: bool = True, contact_forces: bool = False,
               arrow_scale: Optional[float] = None,
               color_range: Optional[Sequence[float]] = None, reference: Any = None,
               backend: str = "auto") -> bytes:
    """The world's current state as PNG bytes (width x height, RGB).

    Args:
        color: "body" (each body its colour), "stress" (von Mises per tet, Pa), "displacement"
            (|x - reference| per vertex, m; reference default the rest positions) or "speed"
            (|v|, m/s); the others than "body" with a colour bar.
        pins: red markers on pinned (and driven) vertices.
        colliders: draw the colliders at their poses.
        contact_forces: the contact forces of the last step as arrows (m per N: `arrow_scale`,
            default the largest 25 % of the bodies' size).
        color_range: (lo, hi) a fixed colour scale; default 0 to the largest value now.
        backend: "auto", "osmesa" (libdefsim_render) or "pyvista".

    Raises defsim.Error with status BACKEND_UNAVAILABLE when the renderer asked for (for "auto":
    every renderer) is missing or no off-screen context can be made, InvalidArgumentError for an
    empty world, a bad size, colour, range or reference."""
    _check(color, width, height, backend)
    if not world.bodies:
        raise InvalidArgumentError("the world has no body to draw")
    rng = (0.0, 0.0)
    if color_range is not None:
        lo, hi = (float(v) for v in color_range)
        if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
            raise InvalidArgumentError("color_range: (lo, hi) with hi > lo, finite")
        rng = (lo, hi)
    if arrow_scale is not None and not (np.isfinite(arrow_scale) and arrow_scale > 0):
        raise InvalidArgumentError("arrow_scale: m per N, > 0")
    kw = dict(width=int(width), height=int(height), color=color, pins=pins, colliders=colliders,
              contact_forces=contact_forces, arrow_scale=arrow_scale or 0.0, color_range=rng,
              reference=reference)
    if backend == "auto":
        have = backends()
        if not have:
            raise Error("no renderer: libdefsim_render (the tools built with OSMesa) is not "
                        "installed and PyVista is not importable (pip install "
                        "'defsim-fem[display]', or pip install pyvista)", Status.BACKEND_UNAVAILABLE)
        backend = have[0]
    if backend == "osmesa":
        return _render_osmesa(world, **kw)
    if not _has_pyvista():
        raise Error("backend 'pyvista' needs PyVista: pip install 'defsim-fem[display]' (or pip "
                    "install pyvista)", Status.BACKEND_UNAVAILABLE)
    return _render_pyvista(world, **kw)


def _reference(world: Any, reference: Any) -> np.ndarray:
    from . import _arrays
    from .io import _rest_positions
    ref = _rest_positions(world) if reference is None else _arrays.points(
        reference, "reference", world.vertex_count)
    return np.ascontiguousarray(ref, dtype=np.float64)


def _render_osmesa(world: Any, *, width: int, height: int, color: str, pins: bool,
                   colliders: bool, contact_forces: bool, arrow_scale: float,
                   color_range: Tuple[float, float], reference: Any) -> bytes:
    from .io import frame_cells
    lib = _render_lib()
    types, offsets, conn, body = frame_cells(world)
    ref = _reference(world, reference)
    d = ffi.new("defsim_render_world_def *")
    lib.defsim_render_world_def_init(d, ffi.sizeof("defsim_render_world_def"))
    keep = [ffi.from_buffer("uint8_t[]", types), ffi.from_buffer("int64_t[]", offsets),
            ffi.from_buffer("int64_t[]", conn), ffi.from_buffer("int32_t[]", body),
            ffi.from_buffer("double[]", ref)]
    d.width, d.height = width, height
    d.cell_count = int(types.shape[0])
    d.types, d.offsets, d.conn, d.body, d.reference = keep
    d.color = COLORS.index(color)
    d.color_range = list(color_range)
    d.pins = 1 if pins else 0
    d.colliders = 1 if colliders else 0
    d.contact_arrows = 1 if contact_forces else 0
    d.arrow_scale = arrow_scale
    d.gravity = list(world.gravity)
    err = ffi.new("char[]", 1024)
    fd, path = tempfile.mkstemp(suffix=".png", prefix="defsim_")
    os.close(fd)
    try:
        st = lib.defsim_render_world_png(path.encode("utf-8"), world._live(), d, err, 1024)
        if st < 0:
            raise error_from_status(st, ffi.string(err).decode("utf-8", "replace"))
        with open(path, "rb") as f:
            return f.read()
    finally:
        os.unlink(path)
        del keep


#: Body colours of ``defsim run`` (tools/scene_output.c), for the PyVista path.
_PALETTE = ((0.85, 0.45, 0.20), (0.25, 0.55, 0.85), (0.35, 0.70, 0.35), (0.80, 0.30, 0.45),
            (0.60, 0.45, 0.80), (0.85, 0.75, 0.25))


def _pyvista() -> Any:
    # No display: let VTK go straight to its EGL (or OSMesa) window instead of failing on X.
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv
    return pv


def _render_pyvista(world: Any, *, width: int, height: int, color: str, pins: bool,
                    colliders: bool, contact_forces: bool, arrow_scale: float,
                    color_range: Tuple[float, float], reference: Any) -> bytes:
    from .io import write_vtu
    pv = _pyvista()
    with tempfile.TemporaryDirectory(prefix="defsim_") as tmp:
        path = os.path.join(tmp, "frame.vtu")
        has_colliders = write_vtu(world, path, reference=_reference(world, reference),
                                  colliders=colliders)
        grid = pv.read(path)
        col = pv.read(os.path.join(tmp, "frame_colliders.vtu")) if has_colliders else None
        plotter = pv.Plotter(off_screen=True, window_size=(width, height))
        try:
            plotter.set_background("white")
            surf = grid.extract_surface(algorithm=None)
            bar = {"title": _UNITS.get(color, ""), "vertical": False, "color": "black",
                   "position_x": 0.25, "position_y": 0.03, "width": 0.5, "height": 0.08,
                   "title_font_size": 12, "label_font_size": 11, "fmt": "%.3g"}
            # The scale of defsim run: 0 to the largest value, or the range given.
            clim = list(color_range) if color_range[1] > color_range[0] else None
            # OSMesa draws the arrows over everything; here the bodies turn translucent so that
            # arrows into a body (a block on the ground) stay visible.
            opacity = 0.55 if contact_forces else 1.0
            if color == "body":
                bodies = np.asarray(surf.cell_data["body"]).astype(int)
                rgb = np.array([_PALETTE[b % len(_PALETTE)] for b in bodies])
                surf.cell_data["rgb"] = (255 * rgb).astype(np.uint8)
                plotter.add_mesh(surf, scalars="rgb", rgb=True, line_width=3, opacity=opacity)
            elif color == "stress":
                if "von_mises" not in surf.cell_data:
                    raise InvalidArgumentError("color 'stress' needs a body of tets")
                vm = np.asarray(surf.cell_data["von_mises"])
                plotter.add_mesh(surf, scalars="von_mises", preference="cell", cmap="viridis",
                                 clim=clim or [0.0, max(float(vm.max()), 1e-300)],
                                 scalar_bar_args=bar, line_width=3, opacity=opacity)
            else:
                vec = surf.point_data["displacement" if color == "displacement" else "velocity"]
                mag = np.linalg.norm(np.asarray(vec), axis=1)
                surf.point_data["magnitude"] = mag
                plotter.add_mesh(surf, scalars="magnitude", cmap="viridis",
                                 clim=clim or [0.0, max(float(mag.max()), 1e-300)],
                                 scalar_bar_args=bar, line_width=3, opacity=opacity)
            if pins and "pinned" in grid.point_data:
                flags = np.asarray(grid.point_data["pinned"]).reshape(-1) != 0
                if flags.any():
                    plotter.add_points(np.asarray(grid.points)[flags], color=(0.8, 0.12, 0.08),
                                       point_size=10, render_points_as_spheres=True)
            size = float(np.linalg.norm(np.ptp(np.asarray(grid.points), axis=0)))
            if contact_forces and "contact_force" in grid.point_data:
                f = np.asarray(grid.point_data["contact_force"])
                mag = np.linalg.norm(f, axis=1)
                keep = mag > 0.01 * mag.max() if mag.max() > 0 else np.zeros(len(f), bool)
                if keep.any():
                    scale = arrow_scale or 0.25 * size / mag.max()
                    pts = pv.PolyData(np.asarray(grid.points)[keep])
                    pts["force"] = f[keep]
                    pts["length"] = mag[keep] * scale
                    arrows = pts.glyph(orient="force", scale="length", factor=1.0,
                                       geom=pv.Arrow())
                    plotter.add_mesh(arrows, color=(0.95, 0.62, 0.08))
            if col is not None and col.n_cells:
                shape = np.asarray(col.cell_data["shape"]).reshape(-1)
                planes = col.extract_cells(np.flatnonzero(shape == 0))
                solids = col.extract_cells(np.flatnonzero(shape != 0))
                if solids.n_cells:
                    plotter.add_mesh(solids, color=(0.6, 0.6, 0.64))
                if planes.n_cells:   # the ground: light, behind the bodies
                    plotter.add_mesh(planes, color=(0.9, 0.9, 0.9), show_edges=True,
                                     edge_color=(0.75, 0.75, 0.75))
            # The automatic camera of defsim run: 35 degrees azimuth, 20 degrees down, "up"
            # against gravity.
            g = np.asarray(world.gravity, dtype=float)
            up = -g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0.0, 1.0, 0.0])
            ref = np.array([0, 0, 1.0]) if abs(up[2]) < 0.9 else np.array([1.0, 0, 0])
            fwd = ref - np.dot(ref, up) * up
            fwd /= np.linalg.norm(fwd)
            side = np.cross(up, fwd)
            az, el = np.radians(35.0), np.radians(20.0)
            view = np.cos(el) * (np.cos(az) * fwd + np.sin(az) * side) + np.sin(el) * up
            lo, hi = np.min(grid.points, axis=0), np.max(grid.points, axis=0)
            centre = 0.5 * (lo + hi)
            dist = 0.75 * max(size, 1e-3) / np.tan(np.radians(35.0) / 2)
            plotter.camera_position = [tuple(centre + dist * view), tuple(centre), tuple(up)]
            plotter.camera.view_angle = 35.0
            out = os.path.join(tmp, "frame.png")
            plotter.screenshot(out)
        finally:
            plotter.close()
        with open(out, "rb") as f:
            return f.read()


def png_or_none(world: Any, **kw: Any) -> Optional[bytes]:
    """render_png, or None when no renderer is available or the world is empty or closed (what
    IPython expects of ``_repr_png_``)."""
    if getattr(world, "closed", True) or not world.bodies or not available():
        return None
    try:
        return render_png(world, **kw)
    except Error:
        return None


def _html(png: bytes, caption: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure style="margin:0"><img src="data:image/png;base64,{data}" '
            f'alt="{html.escape(caption)}"/><figcaption style="font-size:small">'
            f'{html.escape(caption)}</figcaption></figure>')


def _caption(world: Any, color: str, backend: str) -> str:
    n_pinned = 0
    try:
        n_pinned = int(world.pinned().sum())
    except (AttributeError, Error):
        pass
    return (f"t = {world.time:.6g} s, {len(world.bodies)} bodies, {world.vertex_count} vertices, "
            f"{n_pinned} pinned, {len(getattr(world, 'colliders', []))} colliders; colour: "
            f"{_UNITS.get(color, 'by body')}; drawn with {backend}")


def html_or_none(world: Any, **kw: Any) -> Optional[str]:
    """An HTML figure (the PNG inline, and a caption: time, counts, colour) or None, for
    ``_repr_html_``."""
    png = png_or_none(world, **kw)
    if png is None:
        return None
    backend = kw.get("backend", "auto")
    return _html(png, _caption(world, kw.get("color", "body"),
                               backends()[0] if backend == "auto" else backend))


class Picture:
    """A picture of a world's state with chosen settings (the arguments of render_png),
    rendered once when made; Jupyter shows it (``_repr_png_``, ``_repr_html_``).

        defsim.display.Picture(world, color="stress", contact_forces=True)
    """

    def __init__(self, world: Any, width: int = 640, height: int = 400, **kw: Any) -> None:
        self.settings = dict(kw)
        self.png = render_png(world, width, height, **kw)
        backend = kw.get("backend", "auto")
        self.caption = _caption(world, kw.get("color", "body"),
                                backends()[0] if backend == "auto" else backend)

    def _repr_png_(self) -> bytes:
        return self.png

    def _repr_html_(self) -> str:
        return _html(self.png, self.caption)

    def save(self, path: "os.PathLike[str] | str") -> None:
        """Writes the PNG to `path`."""
        with open(path, "wb") as f:
            f.write(self.png)
