# SPDX-License-Identifier: MIT
"""Shared fixtures. The suite runs against the libdefsim that DEFSIM_LIBRARY names (ctest sets it
to the build's), or the one the installed package bundles."""
from __future__ import annotations

from typing import Iterator

import numpy as np
import pytest

import defsim


@pytest.fixture
def world() -> Iterator[defsim.World]:
    """A symplectic Euler world with default gravity, closed after the test."""
    with defsim.World("symplectic_euler") as w:
        yield w


@pytest.fixture
def box() -> defsim.Mesh:
    """A 2 x 1 x 1 cell box on [0, 0.4] x [0, 0.2] x [0, 0.2]: 12 vertices, 12 tets."""
    return defsim.mesh_box((0, 0, 0), (0.4, 0.2, 0.2), cells=(2, 1, 1))


def perturbed(x: np.ndarray, scale: float, seed: int = 1) -> np.ndarray:
    """x plus a fixed pseudo-random displacement of the given size."""
    rng = np.random.default_rng(seed)
    return x + scale * rng.uniform(-1.0, 1.0, size=x.shape)
