# SPDX-License-Identifier: MIT
"""The scenes (and any mesh files they use) that ship with defsim, as package data.

    import defsim.scenes
    defsim.scenes.names()                # ['cantilever', 'cloth', ...]
    defsim.scenes.path("cantilever")     # .../defsim/scenes/cantilever.json

An installed package (the wheel, pip install) holds them in this folder; a source checkout has
them in the repository's ``tests/scenes``, where the tests, benchmarks and the renderer read the
same files. ``python -m defsim.scenes`` lists them, ``python -m defsim.scenes NAME`` prints a
path (for the command line: ``defsim run "$(python -m defsim.scenes cantilever)"``).
"""
from __future__ import annotations

import difflib
import os
from typing import List

__all__ = ["directory", "names", "path"]

_HERE = os.path.dirname(os.path.abspath(__file__))
# bindings/python/src/defsim/scenes -> the repository's tests/scenes
_SOURCE = os.path.normpath(os.path.join(_HERE, *[os.pardir] * 5, "tests", "scenes"))


def directory() -> str:
    """The folder that holds the shipped scenes: the package's own, else the source tree's."""
    if any(f.endswith(".json") for f in os.listdir(_HERE)):
        return _HERE
    if os.path.isdir(_SOURCE):
        return _SOURCE
    raise FileNotFoundError(f"defsim.scenes: no scenes in {_HERE} (an installed package) or "
                            f"{_SOURCE} (a source checkout)")


def names() -> List[str]:
    """The shipped scenes' names (file names without ``.json``), sorted."""
    return sorted(f[:-5] for f in os.listdir(directory()) if f.endswith(".json"))


def path(name: str) -> str:
    """The path of a shipped scene (``"cantilever"`` or ``"cantilever.json"``) or of a file the
    scenes use (a mesh, by its file name). Raises FileNotFoundError naming the closest names."""
    d = directory()
    for cand in (name, name + ".json"):
        p = os.path.join(d, cand)
        if os.sep not in name and os.path.isfile(p):
            return p
    close = difflib.get_close_matches(name, names(), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else f"; the scenes: {', '.join(names())}"
    raise FileNotFoundError(f"defsim.scenes: no scene {name!r} in {d}{hint}")
