# SPDX-License-Identifier: MIT
"""Reading and writing: VTK frames and series of a world, meshes through meshio, scene files.

* ``write_vtu(world, path)`` and ``Series(folder)`` write the frames of ``defsim run`` with
  its own C writer (libdefsim_scene, ``defsim_vtk_write_world``): the bodies' .vtu (points,
  cells, velocity and every field ``defsim run`` writes: stress, displacement, pin, attachment
  and contact forces, pinned), and with colliders their geometry in a second .vtu and a .vtm
  multiblock of both, with the .pvd series that list them.
* ``read_mesh(path)`` reads any mesh file that meshio reads (.vtu, .vtk, .msh, .mesh, .inp,
  .med, .xdmf, ...) into a ``defsim.Mesh``: tets make a tet body, triangles a cloth, lines a
  rope. Needs the optional extra: ``pip install 'defsim-fem[io]'``.
* ``load_scene(path)`` reads a scene file with the parser of ``defsim run`` (libdefsim_scene,
  ``defsim_scene_load``) and gives a ``Scene`` whose ``world`` is a ``defsim.World``.
"""
from __future__ import annotations

import os
from typing import Any, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from . import _arrays
from ._errors import (Error, FileError, InvalidArgumentError, InvalidMeshError, Status,
                      error_from_status)
from ._mesh import Mesh
from ._native import ffi, open_extra
from ._world import Topology, World, tet_boundary

__all__ = ["write_vtu", "Series", "read_mesh", "load_scene", "Scene", "frame_cells"]

PathLike = Union[str, "os.PathLike[str]"]

_VTK_LINE, _VTK_TRIANGLE, _VTK_TETRA, _VTK_QUADRATIC_TETRA = 3, 5, 10, 24


def _scene_lib() -> Any:
    try:
        return open_extra("scene")
    except OSError as exc:
        raise Error(f"defsim.io needs libdefsim_scene (built with the tools): {exc}",
                    Status.BACKEND_UNAVAILABLE) from exc


def _raise(status: int, err: Any) -> None:
    if status < 0:
        raise error_from_status(status, ffi.string(err).decode("utf-8", "replace"))


def frame_cells(world: World) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cells of a frame as ``defsim run`` writes them: for each body in order, its tets,
    else its triangles, else its line springs. Returns (types uint8, offsets int64 (end of
    each cell), connectivity int64 (world vertex indices), body int32 (body index per cell))."""
    types, conn, body = [], [], []
    for i, b in enumerate(world.bodies):
        topo = world.topology(b)
        off = b.vertex_offset
        tet_kind = _VTK_QUADRATIC_TETRA if topo.tets.shape[1] == 10 else _VTK_TETRA
        for cells, kind in ((topo.tets, tet_kind), (topo.triangles, _VTK_TRIANGLE),
                            (topo.lines, _VTK_LINE)):
            if cells.size:
                conn.append(cells.reshape(-1).astype(np.int64) + off)
                types.append(np.full(cells.shape[0], kind, np.uint8))
                body.append(np.full(cells.shape[0], i, np.int32))
                break
    if not types:
        return (np.zeros(0, np.uint8), np.zeros(0, np.int64), np.zeros(0, np.int64),
                np.zeros(0, np.int32))
    t = np.concatenate(types)
    sizes = np.select([t == _VTK_QUADRATIC_TETRA, t == _VTK_TETRA, t == _VTK_TRIANGLE],
                      [10, 4, 3], 2).astype(np.int64)
    return t, np.cumsum(sizes), np.concatenate(conn), np.concatenate(body)


def _rest_positions(world: World) -> np.ndarray:
    parts = [world.topology(b).rest for b in world.bodies]
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def write_vtu(world: World, path: PathLike, *, time: Optional[float] = None,
              reference: Any = None, fields: bool = True, colliders: bool = True,
              plane: Any = None) -> bool:
    """Writes the world's current state as ``defsim run`` writes a frame, with its C writer
    (``defsim_vtk_write_world``): the same arrays, evaluated by the same code.

    `path` (a .vtu) holds the bodies: points, cells (each body's tets, else its triangles, else
    its line springs), point data ``velocity``, cell data ``body``, and with `fields` the
    arrays the world has: ``cauchy_stress`` (9), ``von_mises`` (Pa) and ``energy_density``
    (J/m^3) per cell (zero for triangles and lines), point data ``displacement`` (m),
    ``pin_force`` and ``pinned`` (with pins), ``attachment_force`` (with attachments) and
    ``contact_force`` (N, colliders and body contact, of the last step; with colliders or body
    contact). With `colliders` and a world that has colliders, also
    ``<stem>_colliders.vtu`` (their geometry at the current poses: planes as squares sized to
    the scene, or as `plane` = (centre x, y, z, half side) gives) and the multiblock
    ``<stem>.vtm`` holding both, which ParaView opens as the whole scene. All written
    atomically.

    Args:
        world: the World (bodies made by ``add_body`` or by a scene).
        path: the .vtu file; its folder must exist.
        time: the frame's time (field data ``TimeValue``), default ``world.time``.
        reference: (n, 3) positions that point data ``displacement`` is measured from; default
            the bodies' rest positions.
        fields: False writes only positions, velocities and body ids.
        colliders: False writes the bodies' .vtu alone.
        plane: where planes are drawn (4 numbers), default sized to the scene now.

    Returns True when the .vtm (and the colliders' .vtu) were written.
    Raises FileError (cannot write), InvalidArgumentError (bad reference, a path not ending in
    .vtu), and the errors of ``defsim.Error`` when libdefsim_scene is missing
    (BACKEND_UNAVAILABLE).
    """
    return _write_world(world, path, time, reference, fields, colliders, plane)[0]


def _write_world(world: World, path: PathLike, time: Optional[float], reference: Any,
                 fields: bool, colliders: bool, plane: Any) -> Tuple[bool, Tuple[float, ...]]:
    lib = _scene_lib()
    n = world.vertex_count
    types, offsets, conn, body = frame_cells(world)
    d = ffi.new("defsim_vtk_frame_def *")
    lib.defsim_vtk_frame_def_init(d, ffi.sizeof("defsim_vtk_frame_def"))
    d.cell_count = int(types.shape[0])
    keep = [ffi.from_buffer("uint8_t[]", types), ffi.from_buffer("int64_t[]", offsets),
            ffi.from_buffer("int64_t[]", conn), ffi.from_buffer("int32_t[]", body)]
    d.types, d.offsets, d.conn, d.body = keep
    ref = None
    if fields:
        ref = _rest_positions(world) if reference is None else _arrays.points(reference,
                                                                               "reference", n)
        ref = np.ascontiguousarray(ref, dtype=np.float64)
        d.reference = _arrays.dptr(ref) if ref.size else ffi.NULL
    d.fields = ((lib.DEFSIM_VTK_ALL & ~lib.DEFSIM_VTK_COLLIDERS if fields else 0) |
                (lib.DEFSIM_VTK_COLLIDERS if colliders else 0))
    if plane is not None:
        p = np.asarray(plane, dtype=np.float64).reshape(-1)
        if p.shape != (4,) or not np.all(np.isfinite(p)) or not p[3] > 0:
            raise InvalidArgumentError("plane: (centre x, y, z, half side > 0), 4 finite numbers")
        d.plane_center = list(p[:3])
        d.plane_half = float(p[3])
    err = ffi.new("char[]", 1024)
    out = ffi.new("double[4]")
    vtm = ffi.new("int32_t *")
    t = world.time if time is None else _arrays.c_double(time, "time")
    st = lib.defsim_vtk_write_world(_arrays.path_bytes(path), world._live(), d, t, out, vtm,
                                    err, 1024)
    _raise(st, err)
    del keep, ref
    return bool(vtm[0]), tuple(out[i] for i in range(4))


def _write_pvd(path: str, files: List[str], times: List[float]) -> None:
    lib = _scene_lib()
    names = [ffi.new("char[]", f.encode("utf-8")) for f in files]
    err = ffi.new("char[]", 1024)
    st = lib.defsim_vtk_write_pvd(path.encode("utf-8"), len(names), ffi.new("double[]", times),
                                  ffi.new("char *[]", names), err, 1024)
    _raise(st, err)


class Series:
    """A time series of frames with the .pvd collections that list them, as ``defsim run``
    writes them. Each ``write(world)`` adds ``<folder>/<name>_<NNNNN>.vtu`` (the bodies) and
    rewrites ``<folder>/<name>.pvd``; with colliders also ``<name>_<NNNNN>_colliders.vtu`` and
    ``<name>_<NNNNN>.vtm``, listed by ``<folder>/<name>_scene.pvd`` (the whole scene: open this
    one in ParaView). The series is complete after every frame.

    Displacement is measured from the first frame written (as ``defsim run`` measures it from
    the initial state) unless `reference` is given; planes are drawn as squares sized to the
    scene of the first frame.

        with defsim.io.Series("out", name="beam") as series:
            for frame in range(50):
                world.step(1e-3, steps=10)
                series.write(world)
    """

    def __init__(self, folder: PathLike, name: str = "frames", *, reference: Any = None,
                 fields: bool = True, colliders: bool = True) -> None:
        if not name or any(c in name for c in '/\\"<>&'):
            raise InvalidArgumentError(f"name {name!r}: needs a plain file name")
        self.folder = os.fspath(folder)
        self.name = name
        self.fields = fields
        self.colliders = colliders
        self.files: List[str] = []
        self.times: List[float] = []
        self.scene_files: List[str] = []
        self.scene_times: List[float] = []
        self._plane: Optional[Tuple[float, ...]] = None
        self._reference = None if reference is None else np.array(reference, dtype=np.float64)
        os.makedirs(self.folder, exist_ok=True)

    @property
    def pvd_path(self) -> str:
        return os.path.join(self.folder, f"{self.name}.pvd")

    @property
    def scene_pvd_path(self) -> str:
        """The .pvd of the .vtm frames (bodies and colliders); written once a frame has
        colliders."""
        return os.path.join(self.folder, f"{self.name}_scene.pvd")

    def write(self, world: World, time: Optional[float] = None) -> str:
        """Writes the next frame of `world` and updates the .pvd files. Returns the .vtu's
        path."""
        if self._reference is None:
            self._reference = world.positions
        stem = f"{self.name}_{len(self.files):05d}"
        path = os.path.join(self.folder, stem + ".vtu")
        t = world.time if time is None else float(time)
        vtm, self._plane = _write_world(world, path, t, self._reference, self.fields,
                                        self.colliders, self._plane)
        self.files.append(stem + ".vtu")
        self.times.append(t)
        _write_pvd(self.pvd_path, self.files, self.times)
        if vtm:
            self.scene_files.append(stem + ".vtm")
            self.scene_times.append(t)
            _write_pvd(self.scene_pvd_path, self.scene_files, self.scene_times)
        return path

    def __enter__(self) -> "Series":
        return self

    def __exit__(self, *exc: Any) -> None:
        pass

    def __len__(self) -> int:
        return len(self.files)


# -- meshes through meshio -------------------------------------------------------------------

#: meshio cell types that are volumes defsim cannot simulate (no silent dropping).
_OTHER_VOLUMES = ("tetra10", "tetra20", "hexahedron", "hexahedron20", "hexahedron27", "wedge",
                  "wedge15", "pyramid", "pyramid13")


def _meshio() -> Any:
    try:
        import meshio
    except ImportError as exc:
        raise ImportError("defsim.io.read_mesh needs meshio: pip install 'defsim-fem[io]' "
                          "(or pip install meshio)") from exc
    return meshio


def _unique_edges(cells: np.ndarray) -> np.ndarray:
    k = cells.shape[1]
    edges = np.concatenate([cells[:, [a, (a + 1) % k]] for a in range(k if k > 2 else 1)])
    edges = np.sort(edges, axis=1)
    return np.unique(edges, axis=0).astype(np.int32)


def read_mesh(path: PathLike, file_format: Optional[str] = None) -> Mesh:
    """Reads a mesh file with meshio (any format it reads: .vtu, .vtk, .msh, .mesh, .inp,
    .med, .xdmf, .ply, .obj, .off, .stl ...; `file_format` as meshio names it, else from the
    extension) into a Mesh that ``World.add_body`` takes:

    * linear tets ("tetra" blocks) make a tet mesh: tets reordered to positive orientation,
      their outward boundary as triangles; surface and line blocks beside them are ignored;
    * else triangles make a cloth: the triangles and their unique edges as springs (no
      bending springs);
    * else lines ("line" blocks) make a rope or net: the unique segments as springs.

    Vertices no element uses are dropped; the others keep their order. 2D points get z = 0.
    Raises ImportError without meshio, FileError when meshio cannot read the file,
    InvalidMeshError for a volume mesh of other elements (quadratic tets: ``defsim.mesh_load``
    reads them from Gmsh and TetGen files; hexahedra, prisms, pyramids: convert them to linear
    tets first) or a file with no usable cells.
    """
    meshio = _meshio()
    try:
        m = meshio.read(os.fspath(path), file_format=file_format)
    except (Exception, SystemExit) as exc:   # meshio raises ReadError, ValueError ..., or exits
        raise FileError(f"{os.fspath(path)}: meshio cannot read it: {exc}", Status.IO) from exc
    blocks: Dict[str, List[np.ndarray]] = {}
    for block in m.cells:
        blocks.setdefault(block.type, []).append(np.asarray(block.data, dtype=np.int64))
    other = sorted(t for t in blocks if t in _OTHER_VOLUMES)
    pts = np.asarray(m.points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise InvalidMeshError(f"{os.fspath(path)}: points of shape {pts.shape}", Status.INVALID_MESH)
    if pts.shape[1] == 2:
        pts = np.hstack([pts, np.zeros((pts.shape[0], 1))])
    if "tetra" in blocks:
        cells, kind = np.concatenate(blocks["tetra"]), "tetra"
    elif other:
        raise InvalidMeshError(f"{os.fspath(path)}: {', '.join(other)} cells: defsim simulates "
                               f"linear tets (convert the mesh to tetra)", Status.INVALID_MESH)
    elif "triangle" in blocks:
        cells, kind = np.concatenate(blocks["triangle"]), "triangle"
    elif "line" in blocks:
        cells, kind = np.concatenate(blocks["line"]), "line"
    else:
        raise InvalidMeshError(f"{os.fspath(path)}: no tetra, triangle or line cells (found "
                               f"{sorted(blocks) or 'none'})", Status.INVALID_MESH)
    if cells.size and (cells.min() < 0 or cells.max() >= pts.shape[0]):
        raise InvalidMeshError(f"{os.fspath(path)}: a {kind} cell names a point out of range",
                               Status.INVALID_MESH)
    used = np.unique(cells)
    remap = np.full(pts.shape[0], -1, np.int64)
    remap[used] = np.arange(used.size)
    pos = np.ascontiguousarray(pts[used])
    cells = remap[cells].astype(np.int32)
    if kind == "tetra":
        d = pos[cells[:, :3]] - pos[cells[:, 3:4]]
        negative = np.linalg.det(d) < 0
        cells[negative] = cells[negative][:, [1, 0, 2, 3]]
        return Mesh(positions=pos, tets=np.ascontiguousarray(cells),
                    triangles=tet_boundary(pos, cells))
    if kind == "triangle":
        return Mesh(positions=pos, triangles=np.ascontiguousarray(cells),
                    springs=_unique_edges(cells))
    return Mesh(positions=pos, springs=_unique_edges(cells))


# -- scene files -----------------------------------------------------------------------------

class Scene:
    """A scene file loaded with the parser of ``defsim run`` (``defsim_scene_load`` in
    libdefsim_scene), so that the same JSON gives the same world, errors and all.

    Attributes (from the file): ``name``, ``backend``, ``step`` (h, s), ``duration`` (s),
    ``frame_steps``, ``frames``, ``gravity``, ``body_names``. ``world`` builds the World on
    first use (backend, options, bodies, pins, forces, driven pins, attachments), a
    ``defsim.World`` like any other. Step it with ``Scene.step`` / ``Scene.run`` (which move
    driven pins and keyframed attachments along their paths); ``world.step`` alone does not.
    """

    def __init__(self, path: Union[PathLike, Mapping[str, Any], str],
                 overrides: Optional[Mapping[str, Any]] = None, *,
                 folder: Optional[PathLike] = None) -> None:
        import json
        lib = _scene_lib()
        self._lib = lib
        text = _scene_text(path)
        self.path = "<scene>" if text is not None else os.fspath(path)   # type: ignore[arg-type]
        items = []
        for key, value in (overrides or {}).items():
            given = value if isinstance(value, str) else json.dumps(value)
            items.append(ffi.new("char[]", f"{key}={given}".encode("utf-8")))
        out = ffi.new("defsim_scene **")
        err = ffi.new("char[]", 4096)
        arg = ffi.new("char *[]", items) if items else ffi.NULL
        if text is not None:
            data = text.encode("utf-8")
            where = b"" if folder is None else os.fsencode(folder)
            st = lib.defsim_scene_load_string(data, len(data), b"<scene>", where, arg,
                                              len(items), out, err, 4096)
        else:
            st = lib.defsim_scene_load(_arrays.path_bytes(path), arg, len(items), out, err,
                                       4096)
        _raise(st, err)
        self._ptr = ffi.gc(out[0], lib.defsim_scene_free)
        info = ffi.new("defsim_scene_info *")
        info.size = ffi.sizeof("defsim_scene_info")
        _raise(lib.defsim_scene_get_info(self._ptr, info), ffi.new("char[]", b"bad info"))
        self.name = ffi.string(info.name).decode("utf-8")
        self.backend = ffi.string(info.backend).decode("utf-8")
        self.step_size = float(info.step)
        self.duration = float(info.duration)
        self.frame_steps = int(info.frame_steps)
        self.frames = int(info.frames)
        self.gravity = (float(info.gravity[0]), float(info.gravity[1]), float(info.gravity[2]))
        self._body_count = int(info.body_count)
        self._world: Optional[World] = None

    def _body(self, i: int) -> Any:
        b = ffi.new("defsim_scene_body *")
        b.size = ffi.sizeof("defsim_scene_body")
        _raise(self._lib.defsim_scene_get_body(self._ptr, i, b), ffi.new("char[]", b"bad body"))
        return b

    @property
    def body_names(self) -> List[str]:
        return [ffi.string(self._body(i).name).decode("utf-8") for i in range(self._body_count)]

    @property
    def world(self) -> World:
        """The scene's World, built on first access. Raises the library's error (naming the
        option, body or attachment) when building fails."""
        if self._world is None:
            out = ffi.new("defsim_world **")
            st = self._lib.defsim_scene_build(self._ptr, out)
            if st < 0:
                raise error_from_status(st, ffi.string(
                    self._lib.defsim_scene_last_error(self._ptr)).decode("utf-8", "replace"))
            bodies = []
            for i in range(self._body_count):
                b = self._body(i)
                m = b.mesh
                def arr(ptr: Any, count: int, width: int, dtype: Any) -> np.ndarray:
                    return _arrays.copy_array(ptr, width * count, dtype, (count, width))
                springs = arr(m.springs, m.spring_count, 2, np.int32)
                topo = Topology(arr(m.positions, m.vertex_count, 3, np.float64),
                                arr(m.tets, m.tet_count, 10 if m.tet_nodes == 10 else 4,
                                    np.int32),
                                arr(m.triangles, m.triangle_count, 3, np.int32), springs,
                                springs[:int(b.line_count)])
                bodies.append(((int(b.id.index), int(b.id.generation)), topo))
            self._world = World._adopt(out[0], self.backend, self.gravity, bodies)
            self._world._scene = self   # World.to_scene writes the scene's drives and paths
        return self._world

    def step(self, h: Optional[float] = None, steps: int = 1, *, progress: Any = None) -> None:
        """`steps` steps of h (default the scene's step) with the scene's driven pins and
        keyframed attachments moved along their paths (``defsim_scene_step``); `progress` as in
        ``World.step``. A failed step raises the library's error, as ``World.step`` does."""
        world = self.world
        hh = self.step_size if h is None else _arrays.c_double(h, "h")
        n = _arrays.c_int(steps, "steps")
        if n < 0:
            raise InvalidArgumentError("steps must be >= 0")
        ptr, wptr, lib = self._ptr, world._live(), self._lib
        world._step_loop(n, lambda: lib.defsim_scene_step(ptr, wptr, hh), progress)

    def run(self, out: Optional[PathLike] = None, *, duration: Optional[float] = None,
            progress: Any = None) -> World:
        """Runs the scene in frames of ``frame_steps`` steps: ``frames`` of them as ``defsim
        run`` does (its duration rounded up to whole frames), or round(duration / h) steps; with `out`, writes the initial state and every frame as a Series
        (``<out>/<name>.pvd``). `progress` counts steps, as in ``World.step``. Returns the
        world."""
        world = self.world
        # As `defsim run`: whole frames, frames * frame_steps steps for the scene's duration.
        steps = (self.frames * self.frame_steps if duration is None
                 else int(round(_arrays.c_double(duration, "duration") / self.step_size)))
        series = Series(out, self.name) if out is not None else None
        if series is not None:
            series.write(world)
        per = max(1, self.frame_steps)
        from ._world import _progress
        report, close = _progress(progress, steps)
        done = 0
        try:
            while done < steps:
                k = min(per, steps - done)
                self.step(steps=k)
                done += k
                if report is not None:
                    for i in range(done - k, done):
                        report(i + 1, steps)
                if series is not None:
                    series.write(world)
        finally:
            if close is not None:
                close()
        return world

    def _repr_png_(self) -> Optional[bytes]:
        """The scene's world as a picture for Jupyter (``World._repr_png_``)."""
        return self.world._repr_png_()

    def _repr_html_(self) -> Optional[str]:
        """The scene's world as an HTML figure for Jupyter (``World._repr_html_``)."""
        return self.world._repr_html_()

    def __repr__(self) -> str:
        return (f"<defsim.io.Scene {self.name!r}: {self._body_count} bodies, backend "
                f"{self.backend}, h={self.step_size:g} s, duration={self.duration:g} s>")


def _json_default(value: Any) -> Any:
    """numpy arrays and scalars in a scene dict, as JSON lists and numbers."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON")


def _scene_text(source: Any) -> Optional[str]:
    """The JSON text of a scene given as a dict or a JSON string, or None for a path."""
    import json
    if isinstance(source, Mapping):
        try:
            # repr of a float is the shortest text that reads back to the same double
            return json.dumps(source, default=_json_default, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise InvalidArgumentError(f"the scene dict is not JSON: {exc}") from None
    if isinstance(source, str) and source.lstrip().startswith("{"):
        return source
    if isinstance(source, (bytes, bytearray)) and bytes(source).lstrip().startswith(b"{"):
        return bytes(source).decode("utf-8")
    return None


def load_scene(source: Union[PathLike, Mapping[str, Any], str],
               overrides: Optional[Mapping[str, Any]] = None, *,
               folder: Optional[PathLike] = None) -> Scene:
    """Loads a scene (the JSON of ``defsim run``, same parser, same messages) from a file path,
    a dict (what ``json.load`` gives, numpy arrays allowed; ``World.to_scene()`` returns one),
    or a string of JSON text (one that starts with ``{``). Mesh files a dict or string names are
    taken relative to `folder` (default: the working directory); a file's, to its folder.
    `overrides` maps dotted keys to values, as ``defsim run --set key=value``:
    ``{"world.backend": "newton_cholmod", "bodies.0.material.youngs_modulus": 2e5}`` (strings
    are passed as written, other values as JSON). Raises InvalidArgumentError with
    "file:line:col: what" for a scene the parser rejects ("<scene>:line:col" for a dict or
    string), FileError for a scene file or mesh file that cannot be read."""
    return Scene(source, overrides, folder=folder)
