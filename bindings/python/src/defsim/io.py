# SPDX-License-Identifier: MIT
"""Reading and writing: VTK frames and series of a world, meshes through meshio, scene files.

* ``write_vtu(world, path)`` and ``Series(folder)`` write the .vtu / .pvd files of ``defsim
  run`` with its own C writer (libdefsim_scene, ``defsim_vtk_write_vtu``): points, cells (each
  body's tets, else its triangles, else its springs as lines), point data ``velocity`` and
  ``displacement``, cell data ``body``, ``von_mises`` and ``energy_density``.
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

_VTK_LINE, _VTK_TRIANGLE, _VTK_TETRA = 3, 5, 10


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
        for cells, kind in ((topo.tets, _VTK_TETRA), (topo.triangles, _VTK_TRIANGLE),
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
    sizes = np.select([t == _VTK_TETRA, t == _VTK_TRIANGLE], [4, 3], 2).astype(np.int64)
    return t, np.cumsum(sizes), np.concatenate(conn), np.concatenate(body)


def _rest_positions(world: World) -> np.ndarray:
    parts = [world.topology(b).rest for b in world.bodies]
    return np.concatenate(parts) if parts else np.zeros((0, 3))


def write_vtu(world: World, path: PathLike, *, time: Optional[float] = None,
              reference: Any = None, fields: bool = True) -> None:
    """Writes the world's current state as one .vtu frame (written atomically) with the C
    writer of ``defsim run``.

    Args:
        world: the World (bodies made by ``add_body`` or by a scene).
        path: the .vtu file; its folder must exist.
        time: the frame's time (field data ``TimeValue``), default ``world.time``.
        reference: (n, 3) positions that point data ``displacement`` is measured from; default
            the bodies' rest positions.
        fields: False writes only positions, velocities and body ids; True (default) adds
            ``displacement`` (point data, m), ``von_mises`` (Pa) and ``energy_density``
            (J/m^3) per cell (zero for triangles and lines).

    Raises FileError (cannot write), InvalidArgumentError (bad reference), and the errors of
    ``defsim.Error`` when libdefsim_scene is missing (BACKEND_UNAVAILABLE).
    """
    lib = _scene_lib()
    x = world.positions
    v = world.velocities
    n = x.shape[0]
    types, offsets, conn, body = frame_cells(world)
    keep: List[Any] = []
    arrays = ffi.new("defsim_vtk_array[]", 3)
    count = 0
    if fields:
        ref = _rest_positions(world) if reference is None else _arrays.points(reference,
                                                                               "reference", n)
        disp = np.ascontiguousarray(x - ref)
        vm = np.zeros(types.shape[0])
        psi = np.zeros(types.shape[0])
        for i, b in enumerate(world.bodies):
            if world.topology(b).tets.size:
                stress = b.element_stress()
                first = int(np.argmax(body == i))
                vm[first:first + stress.von_mises.shape[0]] = stress.von_mises
                psi[first:first + stress.von_mises.shape[0]] = stress.energy_density
        for name, data, comps, cell in ((b"displacement", disp, 3, 0), (b"von_mises", vm, 1, 1),
                                        (b"energy_density", psi, 1, 1)):
            cname = ffi.new("char[]", name)
            keep += [cname, data]
            arrays[count].name = cname
            arrays[count].components = comps
            arrays[count].cell = cell
            arrays[count].data = _arrays.dptr(data) if data.size else ffi.cast("double *", 0)
            if data.size == 0:
                continue
            count += 1
    err = ffi.new("char[]", 1024)
    t = world.time if time is None else _arrays.c_double(time, "time")
    st = lib.defsim_vtk_write_vtu(
        _arrays.path_bytes(path), n, _arrays.dptr(x), _arrays.dptr(v), int(types.shape[0]),
        ffi.from_buffer("uint8_t[]", types), ffi.from_buffer("int64_t[]", offsets),
        ffi.from_buffer("int64_t[]", conn), ffi.from_buffer("int32_t[]", body), t,
        arrays, count, err, 1024)
    _raise(st, err)


class Series:
    """A time series of .vtu frames with the .pvd collection that lists them (ParaView opens
    the .pvd). Each ``write(world)`` adds ``<folder>/<name>_<NNNNN>.vtu`` and rewrites
    ``<folder>/<name>.pvd``, so the series is complete after every frame.

    Displacement is measured from the first frame written (as ``defsim run`` measures it from
    the initial state) unless `reference` is given.

        with defsim.io.Series("out", name="beam") as series:
            for frame in range(50):
                world.step(1e-3, steps=10)
                series.write(world)
    """

    def __init__(self, folder: PathLike, name: str = "frames", *, reference: Any = None,
                 fields: bool = True) -> None:
        if not name or any(c in name for c in '/\\"<>&'):
            raise InvalidArgumentError(f"name {name!r}: needs a plain file name")
        self.folder = os.fspath(folder)
        self.name = name
        self.fields = fields
        self.files: List[str] = []
        self.times: List[float] = []
        self._reference = None if reference is None else np.array(reference, dtype=np.float64)
        os.makedirs(self.folder, exist_ok=True)

    @property
    def pvd_path(self) -> str:
        return os.path.join(self.folder, f"{self.name}.pvd")

    def write(self, world: World, time: Optional[float] = None) -> str:
        """Writes the next frame of `world` and updates the .pvd. Returns the .vtu's path."""
        if self._reference is None:
            self._reference = world.positions
        file = f"{self.name}_{len(self.files):05d}.vtu"
        path = os.path.join(self.folder, file)
        t = world.time if time is None else float(time)
        write_vtu(world, path, time=t, reference=self._reference, fields=self.fields)
        self.files.append(file)
        self.times.append(t)
        lib = _scene_lib()
        names = [ffi.new("char[]", f.encode("utf-8")) for f in self.files]
        err = ffi.new("char[]", 1024)
        st = lib.defsim_vtk_write_pvd(self.pvd_path.encode("utf-8"), len(names),
                                      ffi.new("double[]", self.times),
                                      ffi.new("char *[]", names), err, 1024)
        _raise(st, err)
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
    InvalidMeshError for a volume mesh of other elements (quadratic tets, hexahedra, prisms,
    pyramids: convert them to linear tets first) or a file with no usable cells.
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
                                arr(m.tets, m.tet_count, 4, np.int32),
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
