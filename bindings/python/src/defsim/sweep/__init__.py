# SPDX-License-Identifier: MIT
"""Parameter sweeps of defsim scenes on Dask (``pip install ./bindings/python[sweep]``).

    from defsim.sweep import grid, run_sweep
    df = run_sweep("tests/scenes/cantilever.json",
                   grid({"bodies.0.material.youngs_modulus": [1e5, 1e6, 1e7],
                         "world.h": [4e-4, 8e-4]}),
                   out="study", workers=2)
    print(df[["bodies.0.material.youngs_modulus", "world.h", "status", "probe0_y"]])

Each variant is the scene with overrides at dotted keys, run by ``defsim run --set KEY=VALUE``
in a subprocess on a Dask worker (an embedded LocalCluster by default, or a scheduler address);
rows are written to ``out/results/*.parquet`` as they arrive, and ``resume=True`` skips the
variants already there. ``defsim-sweep`` is the command line. See the README, "Running sweeps".
"""
from __future__ import annotations

from ._engine import (finish_bench, list_tool_variants, read_results, run_sweep,
                      run_tool_sweep, write_tool_csv)
from ._runner import FinalState, find_defsim, read_vtu
from ._variants import grid, samples, variant_id

__all__ = ["run_sweep", "run_tool_sweep", "write_tool_csv", "finish_bench", "list_tool_variants",
           "read_results", "grid", "samples", "variant_id", "FinalState", "find_defsim",
           "read_vtu"]
