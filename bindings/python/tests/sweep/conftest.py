# SPDX-License-Identifier: MIT
"""Fixtures of the sweep tests: one real LocalCluster of 2 worker processes for the module, the
defsim executable of the build (DEFSIM_EXE, set by ctest) and the shipped scenes."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterator

import pytest

from defsim.sweep import find_defsim

SCENES = Path(__file__).resolve().parents[4] / "tests" / "scenes"


@pytest.fixture(scope="session")
def exe() -> str:
    try:
        return find_defsim()
    except FileNotFoundError as exc:
        pytest.skip(f"no defsim executable: {exc}")


@pytest.fixture(scope="session")
def cantilever() -> Path:
    return SCENES / "cantilever.json"


@pytest.fixture(scope="module")
def cluster() -> Iterator[object]:
    import distributed
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as c:
        yield c


@pytest.fixture
def client(cluster) -> Iterator[object]:
    import distributed
    with distributed.Client(cluster) as c:
        # A test that killed a worker leaves its nanny restarting it: wait for both.
        c.wait_for_workers(2, timeout=60)
        yield c
