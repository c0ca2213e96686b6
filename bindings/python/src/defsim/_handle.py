# SPDX-License-Identifier: MIT
"""What Body and Attachment share: a small value handle (index and generation) of a world."""
from __future__ import annotations

from typing import Any, Tuple

from ._native import ffi


class Handle:
    """A handle to something a World owns, compared by world and id; it keeps its world alive.
    Subclasses name their C id type in ``_ctype`` ("defsim_body_id *")."""

    __slots__ = ("_world", "_index", "_generation", "__weakref__")
    _ctype = ""

    def __init__(self, world: Any, index: int, generation: int) -> None:
        self._world = world
        self._index = index
        self._generation = generation

    @property
    def world(self) -> Any:
        return self._world

    @property
    def id(self) -> Tuple[int, int]:
        """The C id as (index, generation)."""
        return (self._index, self._generation)

    def _cid(self) -> Any:
        c = ffi.new(self._ctype)
        c.index = self._index
        c.generation = self._generation
        return c[0]

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return self._world is other._world and self.id == other.id

    def __hash__(self) -> int:
        return hash((type(self).__name__, id(self._world), self._index, self._generation))

    def __repr__(self) -> str:
        return (f"<defsim.{type(self).__name__} index={self._index} "
                f"generation={self._generation}>")
