# SPDX-License-Identifier: MIT
"""Meshes made or loaded by the library, as numpy arrays."""
from __future__ import annotations

import enum
import os
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence, Union

import numpy as np

from . import _arrays
from ._errors import check, function
from ._native import ffi, lib

__all__ = ["Mesh", "SpringKind", "mesh_box", "mesh_cloth", "mesh_rope", "mesh_load"]


class SpringKind(enum.IntEnum):
    """What a spring of a cloth or rope resists (``defsim_spring_kind``, ``Mesh.spring_kinds``).
    ``World.add_body(mesh, shear_stiffness=..., bend_stiffness=...)`` sets each kind's
    stiffness; stretch springs take the material's."""

    STRETCH = 0   #: structural: neighbours along the grid or the rope
    SHEAR = 1     #: cell diagonals of a cloth
    BEND = 2      #: between every second vertex: resists folding


def _empty(width: int) -> np.ndarray:
    return np.zeros((0, width), dtype=np.int32)


@dataclass
class Mesh:
    """A mesh: vertex positions and the elements over them. Arrays are numpy arrays owned by the
    Mesh (copies of what the library made; the C mesh is freed at once).

    Attributes:
        positions: (n, 3) float64, m.
        tets: (m, 4) int32, positively oriented; or (m, 10) for quadratic tets (the corners,
            then the mid-edge nodes of edges 01, 12, 02, 03, 13, 23: ``defsim_body_def.tet_nodes``).
        triangles: (k, 3) int32: cloth faces, or the outward boundary of the tets.
        springs: (s, 2) int32: cloth edges, rope links.
        spring_kinds: (s,) int32 SpringKind of each spring (cloth and rope meshes), or None:
            all stretch springs.

    ``World.add_body(mesh, material=...)`` takes its positions, tets, springs (with their
    kinds) and triangles (for output and display).
    """

    positions: np.ndarray
    tets: np.ndarray = field(default_factory=lambda: _empty(4))
    triangles: np.ndarray = field(default_factory=lambda: _empty(3))
    springs: np.ndarray = field(default_factory=lambda: _empty(2))
    spring_kinds: Optional[np.ndarray] = None

    @property
    def vertex_count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def tet_count(self) -> int:
        return int(self.tets.shape[0])

    @property
    def triangle_count(self) -> int:
        return int(self.triangles.shape[0])

    @property
    def spring_count(self) -> int:
        return int(self.springs.shape[0])

    def __repr__(self) -> str:
        return (f"Mesh(vertices={self.vertex_count}, tets={self.tet_count}, "
                f"triangles={self.triangle_count}, springs={self.spring_count})")


def _from_c(m: Any) -> Mesh:
    tn = 10 if m.tet_nodes == 10 else 4
    return Mesh(
        positions=_arrays.copy_array(m.positions, 3 * m.vertex_count, np.float64,
                                     (m.vertex_count, 3)),
        tets=_arrays.copy_array(m.tets, tn * m.tet_count, np.int32, (m.tet_count, tn)),
        triangles=_arrays.copy_array(m.triangles, 3 * m.triangle_count, np.int32,
                                     (m.triangle_count, 3)),
        springs=_arrays.copy_array(m.springs, 2 * m.spring_count, np.int32,
                                   (m.spring_count, 2)),
        spring_kinds=(_arrays.copy_array(m.spring_kinds, m.spring_count, np.int32,
                                         (m.spring_count,))
                      if m.spring_kinds != ffi.NULL and m.spring_count > 0 else None))


def _make(name: str, *args: Any, quadratic: bool = False) -> Mesh:
    """Calls a defsim_mesh_* maker: looks the function up first (UnsupportedError if the library
    lacks it), with `quadratic` turns its tets quadratic (``defsim_mesh_make_quadratic``),
    converts the result and frees the C arrays."""
    fn = function(name)
    elevate = function("defsim_mesh_make_quadratic") if quadratic else None
    m = ffi.new("defsim_mesh *")
    m.size = ffi.sizeof("defsim_mesh")
    check(fn(*args, m))
    try:
        if elevate is not None:
            check(elevate(m))
        return _from_c(m)
    finally:
        lib.defsim_mesh_free(m)


def _cells(cells: Union[int, Sequence[int]]) -> "tuple[int, int, int]":
    if isinstance(cells, (int, np.integer)) and not isinstance(cells, bool):
        c = _arrays.c_int(cells, "cells")
        return (c, c, c)
    try:
        seq = list(cells)  # type: ignore[arg-type]
    except TypeError:
        seq = []
    if len(seq) != 3:
        raise _arrays.InvalidArgumentError("cells: expected an integer or three integers")
    return tuple(_arrays.c_int(c, "cells") for c in seq)  # type: ignore[return-value]


def mesh_box(lo: Any = (0.0, 0.0, 0.0), hi: Any = (1.0, 1.0, 1.0),
             cells: Union[int, Sequence[int]] = 1, quadratic: bool = False) -> Mesh:
    """A box of nx * ny * nz hexahedral cells on [lo, hi], each split into 6 positively
    oriented tets (``defsim_mesh_box``); vertex index i + (nx+1)(j + (ny+1) k).

    Args:
        lo, hi: opposite corners (m), hi > lo on every axis.
        cells: (nx, ny, nz), or one integer for all three; each >= 1.
        quadratic: quadratic tets (``defsim_mesh_make_quadratic``): a vertex at every edge's
            middle too (after the lattice's), tets of shape (m, 10), 4 boundary triangles per
            face.

    Returns a Mesh with positions, tets and the boundary triangles.
    Raises InvalidArgumentError (cells < 1, empty or non-finite box), OutOfMemoryError.
    """
    nx, ny, nz = _cells(cells)
    return _make("defsim_mesh_box", list(_arrays.triple(lo, "lo")),
                 list(_arrays.triple(hi, "hi")), nx, ny, nz, quadratic=bool(quadratic))


def mesh_cloth(origin: Any, u: Any, v: Any, nu: int, nv: int) -> Mesh:
    """A rectangular cloth sheet spanned by the edge vectors u and v from `origin` (m), with
    resolution nu along u and nv along v, as ``defsim_mesh_cloth`` defines them: triangles,
    springs (stretch, shear, bend; ``spring_kinds`` tells which, so that
    ``World.add_body(cloth, shear_stiffness=..., bend_stiffness=...)`` sets them by kind).

    Raises UnsupportedError if the loaded library has no ``defsim_mesh_cloth``, and the Error
    subclass of the library's status otherwise (InvalidArgumentError for bad sizes).
    """
    return _make("defsim_mesh_cloth", list(_arrays.triple(origin, "origin")),
                 list(_arrays.triple(u, "u")), list(_arrays.triple(v, "v")),
                 _arrays.c_int(nu, "nu"), _arrays.c_int(nv, "nv"))


def mesh_rope(a: Any, b: Any, segments: int) -> Mesh:
    """A rope from point a to point b (m) of `segments` links: segments + 1 vertices and a
    spring per link, then bending springs between every second vertex (``defsim_mesh_rope``;
    ``spring_kinds`` tells which).

    Raises UnsupportedError if the loaded library has no ``defsim_mesh_rope``, and the Error
    subclass of the library's status otherwise.
    """
    return _make("defsim_mesh_rope", list(_arrays.triple(a, "a")), list(_arrays.triple(b, "b")),
                 _arrays.c_int(segments, "segments"))


def mesh_load(path: Union[str, bytes, "os.PathLike[str]"]) -> Mesh:
    """Loads a mesh file with ``defsim_mesh_load`` (the formats it reads are listed in the C
    header).

    Raises UnsupportedError if the loaded library has no ``defsim_mesh_load``; FileError if the
    file cannot be read or is malformed; InvalidMeshError for bad contents.
    """
    return _make("defsim_mesh_load", _arrays.path_bytes(path))
