# SPDX-License-Identifier: MIT
"""Conversions between Python/numpy values and the C API's flat arrays and scalars."""
from __future__ import annotations

import os
from typing import Any, Optional, Sequence, Tuple

import numpy as np

from ._errors import InvalidArgumentError
from ._native import ffi

_INT32 = np.iinfo(np.int32)


def points(value: Any, name: str, count: Optional[int] = None) -> np.ndarray:
    """`value` as a C-contiguous float64 array of shape (n, 3). A flat array of 3n values is
    accepted too. With `count`, n must equal it. Raises InvalidArgumentError."""
    try:
        a = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidArgumentError(f"{name}: not an array of numbers ({exc})") from None
    if a.ndim == 1 and a.size % 3 == 0:
        a = a.reshape(-1, 3)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InvalidArgumentError(f"{name}: expected shape (n, 3), got {a.shape}")
    if count is not None and a.shape[0] != count:
        raise InvalidArgumentError(f"{name}: expected {count} vertices, got {a.shape[0]}")
    return a


def vector(value: Any, name: str, size: int) -> np.ndarray:
    """`value` as a contiguous float64 array of exactly `size` values (any shape)."""
    try:
        a = np.ascontiguousarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidArgumentError(f"{name}: not an array of numbers ({exc})") from None
    if a.size != size:
        raise InvalidArgumentError(f"{name}: expected {size} values, got {a.size}")
    return a


def indices(value: Any, name: str, width: int) -> np.ndarray:
    """`value` (None, or integers of shape (m, width) or flat) as contiguous int32 (m, width).
    Integers outside the int32 range and non-integer arrays are rejected, never wrapped."""
    if value is None:
        return np.zeros((0, width), dtype=np.int32)
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise InvalidArgumentError(f"{name}: not an array of integers ({exc})") from None
    if a.size == 0:
        return np.zeros((0, width), dtype=np.int32)
    if a.dtype.kind not in "iu":
        raise InvalidArgumentError(f"{name}: expected integers, got dtype {a.dtype}")
    if a.min() < _INT32.min or a.max() > _INT32.max:
        raise InvalidArgumentError(f"{name}: index out of the int32 range")
    a = np.ascontiguousarray(a, dtype=np.int32)
    if a.ndim == 1 and a.size % width == 0:
        a = a.reshape(-1, width)
    if a.ndim != 2 or a.shape[1] != width:
        raise InvalidArgumentError(f"{name}: expected shape (m, {width}), got {a.shape}")
    return a


def c_int(value: Any, name: str) -> int:
    """A Python integer in the int32 range (numpy integers accepted; bools and floats not)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InvalidArgumentError(f"{name}: expected an integer, got {type(value).__name__}")
    v = int(value)
    if not _INT32.min <= v <= _INT32.max:
        raise InvalidArgumentError(f"{name}: {v} is out of the int32 range")
    return v


def c_double(value: Any, name: str) -> float:
    """A real number as a Python float (strings are not numbers here)."""
    if isinstance(value, (str, bytes)):
        raise InvalidArgumentError(f"{name}: expected a number, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InvalidArgumentError(f"{name}: expected a number, got {value!r}") from None


def triple(value: Any, name: str) -> Tuple[float, float, float]:
    v = vector(value, name, 3)
    return (float(v[0]), float(v[1]), float(v[2]))


def dptr(a: Optional[np.ndarray]) -> Any:
    """A `double *` into a float64 array, or NULL for None / an empty array."""
    if a is None or a.size == 0:
        return ffi.NULL
    return ffi.from_buffer("double[]", a)


def iptr(a: Optional[np.ndarray]) -> Any:
    """An `int32_t *` into an int32 array, or NULL for None / an empty array."""
    if a is None or a.size == 0:
        return ffi.NULL
    return ffi.from_buffer("int32_t[]", a)


def path_bytes(path: "os.PathLike[str] | str | bytes", name: str = "path") -> bytes:
    try:
        b = os.fsencode(path)
    except TypeError:
        raise InvalidArgumentError(f"{name}: expected a path, got {type(path).__name__}") from None
    if b"\0" in b:
        raise InvalidArgumentError(f"{name}: contains a NUL byte")
    return b


def copy_array(ptr: Any, count: int, dtype: Any, shape: Sequence[int]) -> np.ndarray:
    """A numpy copy of `count` elements at a C pointer (an empty array for NULL / 0)."""
    if count <= 0 or ptr == ffi.NULL:
        return np.zeros(tuple(0 if i == 0 else s for i, s in enumerate(shape)), dtype=dtype)
    item = np.dtype(dtype).itemsize
    return np.frombuffer(ffi.buffer(ptr, count * item), dtype=dtype).reshape(shape).copy()
