# SPDX-License-Identifier: MIT
"""Status codes and the exceptions that carry them."""
from __future__ import annotations

import enum
from typing import Dict, Optional, Type, Union

from ._native import ffi, lib

__all__ = [
    "Status", "Error", "InvalidArgumentError", "InvalidMeshError", "InvalidMaterialError",
    "BackendUnavailableError", "NotConvergedError", "UnstableError", "OutOfMemoryError",
    "FileError", "StaleIdError", "StaleViewError", "LockedError", "ConflictError",
    "UnsupportedError", "error_from_status",
]


class Status(enum.IntEnum):
    """The library's status codes (``defsim_status``): 0 success, negative errors."""

    OK = 0
    INVALID_ARGUMENT = -1
    INVALID_MESH = -2
    INVALID_MATERIAL = -3
    BACKEND_UNAVAILABLE = -4
    NOT_CONVERGED = -5
    UNSTABLE = -6
    OUT_OF_MEMORY = -7
    IO = -8
    STALE_ID = -9
    LOCKED = -10
    CONFLICT = -11
    CALLBACK = -12
    UNSUPPORTED = -13


class Error(Exception):
    """Base of every error the package raises.

    Attributes:
        status: the library's status code (a Status, or a plain int for a code this package
            does not know), or None for a binding-level error that has no C status
            (UnsupportedError).
        message: the library's detail message (``defsim_world_last_error`` or
            ``defsim_last_error``), or the binding's own for checks done in Python.
    """

    status: Optional[Union[Status, int]]
    message: str
    #: The status a subclass stands for; used when none is given to the constructor.
    default_status: Optional[Status] = None

    def __init__(self, message: str = "", status: Optional[Union[Status, int]] = None) -> None:
        self.status = self.default_status if status is None else status
        self.message = message
        super().__init__(message)

    def __str__(self) -> str:
        if self.status is None:
            return self.message
        text = ffi.string(lib.defsim_status_string(int(self.status))).decode("utf-8", "replace")
        return f"{text}: {self.message}" if self.message else text

    def __reduce__(self):  # keep (message, status) through pickling (multiprocessing)
        return (type(self), (self.message, self.status))


class InvalidArgumentError(Error, ValueError):
    """A NULL pointer, size, count, shape or option out of range (``DEFSIM_ERR_INVALID_ARGUMENT``)."""

    default_status = Status.INVALID_ARGUMENT


class InvalidMeshError(Error, ValueError):
    """Bad indices, non-finite or degenerate geometry (``DEFSIM_ERR_INVALID_MESH``)."""

    default_status = Status.INVALID_MESH


class InvalidMaterialError(Error, ValueError):
    """Non-physical material parameters (``DEFSIM_ERR_INVALID_MATERIAL``)."""

    default_status = Status.INVALID_MATERIAL


class BackendUnavailableError(Error):
    """No backend of that name, or its module failed to load (``DEFSIM_ERR_BACKEND_UNAVAILABLE``)."""

    default_status = Status.BACKEND_UNAVAILABLE


class NotConvergedError(Error):
    """A nonlinear or adaptive solve failed; state unchanged (``DEFSIM_ERR_NOT_CONVERGED``)."""

    default_status = Status.NOT_CONVERGED


class UnstableError(Error, ArithmeticError):
    """A step produced a non-finite state, or a model is undefined there (``DEFSIM_ERR_UNSTABLE``)."""

    default_status = Status.UNSTABLE


class OutOfMemoryError(Error, MemoryError):
    """An allocation failed; state unchanged (``DEFSIM_ERR_OUT_OF_MEMORY``)."""

    default_status = Status.OUT_OF_MEMORY


class FileError(Error):
    """A file could not be read or written, or is malformed (``DEFSIM_ERR_IO``)."""

    default_status = Status.IO


class StaleIdError(Error, LookupError):
    """A body id that is null, removed, or of another world (``DEFSIM_ERR_STALE_ID``)."""

    default_status = Status.STALE_ID


class StaleViewError(StaleIdError):
    """A ``StateView`` used after the world's bodies changed or the world was closed (its
    arrays were moved or freed): take a new one with ``World.state_view()``. Status STALE_ID."""


class LockedError(Error):
    """The world is inside a callback and cannot be changed (``DEFSIM_ERR_LOCKED``)."""

    default_status = Status.LOCKED


class ConflictError(Error):
    """A backend of that name is already registered (``DEFSIM_ERR_CONFLICT``)."""

    default_status = Status.CONFLICT


class CallbackError(Error):
    """A host callback failed or returned a non-finite value; state unchanged
    (``DEFSIM_ERR_CALLBACK``)."""

    default_status = Status.CALLBACK


class UnsupportedError(Error, NotImplementedError):
    """The loaded libdefsim lacks a function this package wraps (an older or smaller build):
    its ``status`` is None, no C call was made; or the world's backend cannot do what the world
    asks, such as body contact on an explicit backend (``DEFSIM_ERR_UNSUPPORTED``; state
    unchanged)."""


_CLASSES: Dict[int, Type[Error]] = {
    Status.INVALID_ARGUMENT: InvalidArgumentError,
    Status.INVALID_MESH: InvalidMeshError,
    Status.INVALID_MATERIAL: InvalidMaterialError,
    Status.BACKEND_UNAVAILABLE: BackendUnavailableError,
    Status.NOT_CONVERGED: NotConvergedError,
    Status.UNSTABLE: UnstableError,
    Status.OUT_OF_MEMORY: OutOfMemoryError,
    Status.IO: FileError,
    Status.STALE_ID: StaleIdError,
    Status.LOCKED: LockedError,
    Status.CONFLICT: ConflictError,
    Status.CALLBACK: CallbackError,
    Status.UNSUPPORTED: UnsupportedError,
}


def error_from_status(status: int, message: str = "") -> Error:
    """The exception for a negative status code: the matching Error subclass, or Error itself
    for a code this package does not know. ``message`` is the library's detail."""
    try:
        code: Union[Status, int] = Status(status)
    except ValueError:
        code = int(status)
    return _CLASSES.get(int(status), Error)(message, code)


def last_error() -> str:
    """``defsim_last_error()``: detail of the last failure of a call without a world."""
    return ffi.string(lib.defsim_last_error()).decode("utf-8", "replace")


def check(status: int) -> None:
    """Raises for a negative status, with ``defsim_last_error()`` as the message."""
    if status < 0:
        raise error_from_status(status, last_error())


def function(name: str):
    """The C function `name`, or raises UnsupportedError if the library (or header) lacks it."""
    try:
        return getattr(lib, name)
    except AttributeError:
        raise UnsupportedError(
            f"{name} is not available: the loaded libdefsim (or its header) does not provide it; "
            f"a newer libdefsim is needed") from None
