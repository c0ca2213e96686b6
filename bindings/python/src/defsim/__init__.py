# SPDX-License-Identifier: MIT
"""defsim: deformable-body simulation (mass-spring networks and tetrahedral FEM) for Python.

A thin, typed layer over the library's C API (``defsim/defsim.h``) through cffi in out-of-line ABI
mode (declarations generated and checked against the compiler when the package is built): no C
compiler is needed at import time. Arrays are numpy float64 (positions, velocities, forces as
(n, 3)) and int32 (indices). Errors raise a subclass of ``defsim.Error`` that carries the
library's status code (``.status``) and message (``.message``).

    import defsim
    mesh = defsim.mesh_box((0, 0, 0), (1, 0.2, 0.2), cells=(10, 2, 2))
    with defsim.World(backend="symplectic_euler", gravity=(0, -9.81, 0)) as world:
        beam = world.add_body(mesh, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                             poisson_ratio=0.3, density=1000))
        world.pin(beam, mesh.positions[:, 0] == 0.0)
        world.step(1e-3, steps=100)
        print(world.positions[:, 1].min(), world.energy().total)

Where the library and header are found: see ``defsim._native`` (``DEFSIM_LIBRARY``,
the copies bundled by ``pip install``, a build tree's declarations, system paths).
"""
from __future__ import annotations

from typing import Tuple

from ._collider import Collider, Pose, Shape
from ._coupling import Attachment, ElementStress, StepError
from ._errors import (BackendUnavailableError, CallbackError, ConflictError, Error, FileError,
                      InvalidArgumentError, InvalidMaterialError, InvalidMeshError, LockedError,
                      NotConvergedError, OutOfMemoryError, StaleIdError, StaleViewError, Status,
                      UnstableError,
                      UnsupportedError, error_from_status)
from ._material import Material, MaterialEval, Model, material_eval
from ._mesh import Mesh, SpringKind, mesh_box, mesh_cloth, mesh_load, mesh_rope
from ._native import header_version_number as _header_version
from ._native import header_version_string as _header_version_string
from ._native import lib as _lib
from ._native import library_path as _library_path
from ._shell import Membrane, Shell, fabrics
from ._state_view import StateView
from ._tape import Tape
from ._view import ViewResult, view, view_available
from ._world import Body, Energy, LogCallback, Pass, Projection, Stats, Topology, World

#: Version of the C header this package was built for (also the package's version).
__version__: str = _header_version_string

#: Path or name of the libdefsim that was loaded.
library_path: str = _library_path


def library_version() -> Tuple[int, int, int]:
    """Version (major, minor, patch) of the loaded libdefsim (``defsim_version_number``).
    Import fails unless it has the header's major version and is at least as new."""
    n = int(_lib.defsim_version_number())
    return (n // 10000, n // 100 % 100, n % 100)


def header_version() -> Tuple[int, int, int]:
    """Version (major, minor, patch) of the header the package was built for."""
    n = _header_version
    return (n // 10000, n // 100 % 100, n % 100)


__all__ = [
    "World", "Body", "StateView", "Attachment", "Collider", "Shape", "Pose", "ElementStress", "StepError", "Energy", "Stats", "Pass", "Projection", "LogCallback",
    "Material", "Model", "MaterialEval", "material_eval",
    "Mesh", "SpringKind", "Topology", "Shell", "Membrane", "fabrics", "mesh_box", "mesh_cloth", "mesh_rope", "mesh_load",
    "Status", "Error", "InvalidArgumentError", "InvalidMeshError", "InvalidMaterialError",
    "BackendUnavailableError", "NotConvergedError", "UnstableError", "OutOfMemoryError",
    "FileError", "StaleIdError", "StaleViewError", "LockedError", "ConflictError", "CallbackError", "UnsupportedError",
    "error_from_status", "library_version", "header_version", "library_path", "__version__",
    "view", "ViewResult", "view_available", "Tape",
]
