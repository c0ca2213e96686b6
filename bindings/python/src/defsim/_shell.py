# SPDX-License-Identifier: MIT
"""Cloth and shells (``defsim_body_def``'s shell fields; docs/shells.md)."""
from __future__ import annotations

import dataclasses
import enum
from typing import Any, Sequence

from . import _arrays
from ._errors import InvalidArgumentError, check, function
from ._native import ffi


class Membrane(enum.IntEnum):
    """A shell's membrane energy (``defsim_shell_membrane``)."""

    NONE = 0
    STVK = 1
    NEOHOOKEAN = 2
    ORTHOTROPIC_STVK = 3


@dataclasses.dataclass
class Shell:
    """The shell of a body of triangles (``World.add_body(..., shell=Shell(...))``), in SI
    units: the body's triangles become membrane elements on their rest planes and its interior
    edges bending hinges with the rest shape's angles (docs/shells.md). Defaults are the
    library's; ``bending_rigidity`` None takes an isotropic membrane's plate rigidity
    E t^3 / (12 (1 - nu^2)) (none for the others), ``bending_rigidity_weft`` None the warp's.
    ``strain_limit`` caps each triangle's largest principal stretch at 1 + strain_limit (a
    barrier; implicit backends with a filtered line search only: newton_cholmod, bdf2, newmark).
    """

    membrane: Membrane = Membrane.NONE
    youngs_modulus: float = 1e6          # Pa (isotropic membranes)
    poisson_ratio: float = 0.3
    thickness: float = 1e-3              # m
    warp_modulus: float = 1e3            # N/m (orthotropic)
    weft_modulus: float = 1e3            # N/m
    shear_modulus: float = 1e3           # N/m
    warp_poisson: float = 0.0
    warp_direction: Sequence[float] = (1.0, 0.0, 0.0)
    areal_density: float = 0.1           # kg/m^2
    bending_rigidity: Any = None         # N m
    bending_rigidity_weft: Any = None    # N m
    strain_limit: float = 0.0            # cap on the principal stretch (0.1: 10 %); 0: none

    @classmethod
    def from_fabric(cls, name: str, **overrides: Any) -> "Shell":
        """The shell of a fabric of the library's table of measured fabrics (docs/shells.md,
        ``defsim_fabric_find``): the orthotropic StVK membrane with the fabric's areal density,
        warp, weft and shear moduli, nu_12 and warp and weft bending rigidities; ``overrides``
        set other fields (``warp_direction``, ...) or replace the table's.

        Raises InvalidMaterialError for a name the table does not have (the message lists the
        table's names), UnsupportedError if the loaded library has no fabric table.
        """
        if not isinstance(name, str) or "\0" in name:
            raise InvalidArgumentError(f"fabric name must be a string, got {name!r}")
        f = ffi.new("defsim_fabric *")
        f.size = ffi.sizeof("defsim_fabric")
        check(function("defsim_fabric_find")(name.encode("utf-8"), f))
        values = dict(membrane=Membrane.ORTHOTROPIC_STVK, areal_density=f.areal_density,
                      warp_modulus=f.warp_modulus, weft_modulus=f.weft_modulus,
                      shear_modulus=f.shear_modulus, warp_poisson=f.warp_poisson,
                      bending_rigidity=f.bending_rigidity,
                      bending_rigidity_weft=f.bending_rigidity_weft)
        values.update(overrides)
        return cls(**values)

    def _fill(self, d: Any) -> None:
        try:
            d.shell_membrane = int(Membrane(self.membrane))
        except ValueError:
            raise InvalidArgumentError(f"shell.membrane {self.membrane!r} is not a Membrane")
        for name in ("youngs_modulus", "poisson_ratio", "thickness", "warp_modulus",
                     "weft_modulus", "shear_modulus", "warp_poisson", "areal_density",
                     "strain_limit"):
            setattr(d, "shell_" + name, _arrays.c_double(getattr(self, name), "shell." + name))
        w = list(self.warp_direction)
        if len(w) != 3:
            raise InvalidArgumentError("shell.warp_direction needs 3 values")
        for i in range(3):
            d.shell_warp_direction[i] = _arrays.c_double(w[i], "shell.warp_direction")
        d.shell_bending_rigidity = (-1.0 if self.bending_rigidity is None else
                                    _arrays.c_double(self.bending_rigidity,
                                                     "shell.bending_rigidity"))
        d.shell_bending_rigidity_weft = (-1.0 if self.bending_rigidity_weft is None else
                                         _arrays.c_double(self.bending_rigidity_weft,
                                                          "shell.bending_rigidity_weft"))


def fabrics() -> "list[str]":
    """The names of the library's table of measured fabrics (``defsim_fabric_get``), in its
    order; ``Shell.from_fabric(name)`` makes a shell of one."""
    get = function("defsim_fabric_get")
    out = []
    f = ffi.new("defsim_fabric *")
    f.size = ffi.sizeof("defsim_fabric")
    for i in range(int(function("defsim_fabric_count")())):
        check(get(i, f))
        out.append(ffi.string(f.name).decode("utf-8"))
    return out
