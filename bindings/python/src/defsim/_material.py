# SPDX-License-Identifier: MIT
"""Materials and the pointwise material evaluation."""
from __future__ import annotations

import enum
from typing import Any, NamedTuple, Optional, Union

import numpy as np

from . import _arrays
from ._errors import InvalidArgumentError, check
from ._native import ffi, lib

__all__ = ["Model", "Material", "MaterialEval", "material_eval"]


class Model(enum.IntEnum):
    """Constitutive models (``defsim_model``)."""

    SPRING = 1              #: Hooke springs only: E = k/2 (l - l0)^2 per spring.
    STVK = 2                #: Saint Venant-Kirchhoff.
    COROTATED = 3           #: Co-rotated linear, inversion-safe.
    NEOHOOKEAN = 4          #: Compressible neo-Hookean with log J (undefined for J <= 0).
    STABLE_NEOHOOKEAN = 5   #: Smith, de Goes, Kim 2018; inversion-safe.


def _model(value: Union[str, int, Model]) -> Model:
    if isinstance(value, str):
        key = value.strip().upper().replace("-", "_").replace(" ", "_")
        key = {"NEO_HOOKEAN": "NEOHOOKEAN", "STABLE_NEO_HOOKEAN": "STABLE_NEOHOOKEAN",
               "ST_VK": "STVK", "SPRINGS": "SPRING"}.get(key, key)
        try:
            return Model[key]
        except KeyError:
            raise InvalidArgumentError(
                f"unknown material model {value!r}; one of "
                f"{', '.join(m.name.lower() for m in Model)}") from None
    try:
        return Model(int(value))
    except (ValueError, TypeError):
        raise InvalidArgumentError(f"unknown material model {value!r}") from None


_FIELDS = ("youngs_modulus", "poisson_ratio", "density", "stiffness", "vertex_mass",
           "mass_damping", "stiffness_damping")


class Material:
    """Material parameters of a body, in SI units (``defsim_material``).

    Parameters left as None take the library's defaults for the model (``defsim_material_init``):
    E = 1e6 Pa, nu = 0.3, rho = 1000 kg/m^3, k = 1e3 N/m, vertex mass 0.01 kg for springs (0 for
    tet models), no damping. Values are checked when the material is made and whenever a field
    is assigned, by the library's own rules (``defsim_material_check``, those of
    ``World.add_body``): E finite and > 0, nu in [0, 0.5), density, stiffness, vertex_mass and
    the damping coefficients finite and >= 0. A bad value raises InvalidMaterialError naming the
    field, and an assignment that fails leaves the material as it was. (Whether the model fits a
    body, tets with "spring", is ``add_body``'s check.)

    Args:
        model: "spring", "stvk", "corotated", "neohookean", "stable_neohookean", or a Model.
        youngs_modulus: E in Pa (tet models).
        poisson_ratio: nu in [0, 0.5) (tet models).
        density: rho in kg/m^3; gives the lumped tet masses.
        stiffness: spring stiffness k in N/m, for every spring of the body.
        vertex_mass: kg added to every vertex of the body.
        mass_damping: Rayleigh alpha in 1/s (damping force -alpha M v).
        stiffness_damping: Rayleigh beta in s (damping force -beta K(x) v).

    Example: ``Material("corotated", youngs_modulus=1e5, poisson_ratio=0.3, density=1000)``.
    """

    model: Model
    youngs_modulus: float
    poisson_ratio: float
    density: float
    stiffness: float
    vertex_mass: float
    mass_damping: float
    stiffness_damping: float

    def __init__(self, model: Union[str, int, Model] = "stable_neohookean", *,
                 youngs_modulus: Optional[float] = None, poisson_ratio: Optional[float] = None,
                 density: Optional[float] = None, stiffness: Optional[float] = None,
                 vertex_mass: Optional[float] = None, mass_damping: Optional[float] = None,
                 stiffness_damping: Optional[float] = None) -> None:
        object.__setattr__(self, "model", _model(model))
        c = ffi.new("defsim_material *")
        lib.defsim_material_init(c, ffi.sizeof("defsim_material"), int(self.model))
        given = dict(youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio, density=density,
                     stiffness=stiffness, vertex_mass=vertex_mass, mass_damping=mass_damping,
                     stiffness_damping=stiffness_damping)
        values = {name: float(getattr(c, name)) if given[name] is None
                  else _arrays.c_double(given[name], name) for name in _FIELDS}
        for name, v in values.items():
            object.__setattr__(self, name, v)
        self._check()

    def __setattr__(self, name: str, value: Any) -> None:
        if name not in _FIELDS and name != "model":
            raise AttributeError(f"Material has no field {name!r} (fields: model, "
                                 f"{', '.join(_FIELDS)})")
        old = getattr(self, name)
        object.__setattr__(self, name, _model(value) if name == "model"
                           else _arrays.c_double(value, name))
        try:
            self._check()
        except Exception:
            object.__setattr__(self, name, old)
            raise

    def _check(self) -> None:
        """Raises InvalidMaterialError unless the library accepts these values."""
        c = ffi.new("defsim_material *")
        self._fill(c)
        check(lib.defsim_material_check(c))

    def _fill(self, c: Any) -> None:
        """Writes this material into a ``defsim_material`` cdata (defaults first, so that
        fields a newer header appends keep the library's defaults)."""
        lib.defsim_material_init(c, ffi.sizeof("defsim_material"), int(self.model))
        for name in _FIELDS:
            setattr(c, name, _arrays.c_double(getattr(self, name), name))

    def eval(self, F: Any, *, stress: bool = True, tangent: bool = True) -> "MaterialEval":
        """Same as ``material_eval(self, F, ...)``."""
        return material_eval(self, F, stress=stress, tangent=tangent)

    def __repr__(self) -> str:
        args = ", ".join(f"{n}={getattr(self, n)!r}" for n in _FIELDS)
        return f"Material({self.model.name.lower()!r}, {args})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Material):
            return NotImplemented
        return self.model == other.model and all(
            getattr(self, n) == getattr(other, n) for n in _FIELDS)

    __hash__ = None  # type: ignore[assignment]  # mutable


class MaterialEval(NamedTuple):
    """Result of material_eval. For a batch of deformation gradients (shape (..., 3, 3)) each
    field has the batch shape in front."""

    psi: Union[float, np.ndarray]       #: energy density, J/m^3
    P: Optional[np.ndarray]             #: first Piola-Kirchhoff stress, (..., 3, 3), Pa
    dPdF: Optional[np.ndarray]          #: dP[i,j]/dF[k,l] as (..., 3, 3, 3, 3), Pa


def material_eval(material: Material, F: Any, *, stress: bool = True,
                  tangent: bool = True) -> MaterialEval:
    """Evaluates a tet material at deformation gradients F (``defsim_material_eval``).

    Args:
        material: a tet material (not "spring").
        F: a 3x3 deformation gradient, or an array of them with shape (..., 3, 3).
        stress: compute P (else its field is None).
        tangent: compute dP/dF (else its field is None); indexed ``dPdF[..., i, j, k, l]``
            = dP_ij / dF_kl.

    The stable neo-Hookean energy is not zero at F = I (see the C header); world energies
    subtract that constant, this function does not.

    Raises InvalidArgumentError (spring model, non-finite F, bad shape), InvalidMaterialError
    (bad parameters), UnstableError (neo-Hookean at det F <= 0).
    """
    if not isinstance(material, Material):
        raise InvalidArgumentError("material must be a defsim.Material")
    try:
        Fa = np.ascontiguousarray(F, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidArgumentError(f"F: not an array of numbers ({exc})") from None
    if Fa.ndim < 2 or Fa.shape[-2:] != (3, 3):
        raise InvalidArgumentError(f"F: expected shape (..., 3, 3), got {Fa.shape}")
    batch = Fa.shape[:-2]
    flat = Fa.reshape(-1, 9)
    n = flat.shape[0]
    psi = np.empty(n)
    P = np.empty((n, 9)) if stress else None
    dPdF = np.empty((n, 81)) if tangent else None
    cm = ffi.new("defsim_material *")
    material._fill(cm)
    psi_c = ffi.new("double *")
    for i in range(n):
        st = lib.defsim_material_eval(
            cm, ffi.from_buffer("double[]", flat[i]), psi_c,
            ffi.from_buffer("double[]", P[i]) if P is not None else ffi.NULL,
            ffi.from_buffer("double[]", dPdF[i]) if dPdF is not None else ffi.NULL)
        check(st)
        psi[i] = psi_c[0]
    return MaterialEval(
        psi=float(psi[0]) if batch == () else psi.reshape(batch),
        P=None if P is None else P.reshape(batch + (3, 3)),
        dPdF=None if dPdF is None else dPdF.reshape(batch + (3, 3, 3, 3)))
