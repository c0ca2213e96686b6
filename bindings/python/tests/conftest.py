# SPDX-License-Identifier: MIT
"""Shared fixtures. The suite runs against the libdefsim that DEFSIM_LIBRARY names (ctest sets it
to the build's), or the one the installed package bundles."""
from __future__ import annotations

from typing import Iterator

import os

import numpy as np
import pytest

import defsim


def world_or_skip(backend: str, **kw) -> defsim.World:
    """A World with the backend; the test is skipped only when the build does not have it
    (DEFSIM_TEST_BACKENDS, set by ctest to the build's backends; without it, as from an installed
    package, any BackendUnavailableError skips). A backend the build has must load."""
    try:
        return defsim.World(backend, **kw)
    except defsim.BackendUnavailableError:
        built = os.environ.get("DEFSIM_TEST_BACKENDS")
        if built is not None and backend in built.split(","):
            raise
        pytest.skip(f"backend {backend} is not in this build")


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
