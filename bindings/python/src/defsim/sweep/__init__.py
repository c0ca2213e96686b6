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

from typing import Any

# Names resolve on first use (PEP 562), so that `defsim-sweep` can say which extra is missing
# instead of failing at import.
_EXPORTS = {
    "run_sweep": "_engine", "run_tool_sweep": "_engine", "write_tool_csv": "_engine",
    "finish_bench": "_engine", "list_tool_variants": "_engine", "read_results": "_engine",
    "grid": "_variants", "samples": "_variants", "variant_id": "_variants",
    "FinalState": "_runner", "find_defsim": "_runner", "read_vtu": "_runner",
}
__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'defsim.sweep' has no attribute {name!r}")
    import importlib
    value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list:
    return sorted(list(globals()) + __all__)
