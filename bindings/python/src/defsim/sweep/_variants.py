# SPDX-License-Identifier: MIT
"""Variants of a scene: overrides at dotted keys, from a grid, a list or random samples."""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import random
from typing import Any, Dict, Iterable, List, Mapping, Sequence, Tuple, Union

Overrides = Dict[str, Any]


def variant_id(overrides: Mapping[str, Any]) -> str:
    """A stable id for a set of overrides: 16 hex digits of the SHA-256 of their canonical JSON
    (keys sorted; numbers as JSON writes them, so 1e6 and 1000000.0 are the same variant)."""
    text = json.dumps({str(k): _plain(v) for k, v in overrides.items()}, sort_keys=True,
                      separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _plain(v: Any) -> Any:
    """numpy scalars and tuples as plain JSON values (ints that are floats stay floats)."""
    if hasattr(v, "item") and not isinstance(v, (list, tuple, dict, str)):
        v = v.item()
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    if isinstance(v, list):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, float) and not math.isfinite(v):
        raise ValueError(f"override value {v!r} is not finite")
    return v


def grid(axes: Mapping[str, Sequence[Any]]) -> List[Overrides]:
    """The cartesian product of the axes, the last key varying fastest:
    ``grid({"world.h": [1e-3, 2e-3], "bodies.0.material.youngs_modulus": [1e5, 1e6]})``."""
    keys = list(axes)
    for k in keys:
        if len(axes[k]) == 0:
            raise ValueError(f"grid axis {k!r} has no values")
    return [dict(zip(keys, combo)) for combo in itertools.product(*(axes[k] for k in keys))]


Range = Union[Tuple[float, float], Tuple[float, float, str], Sequence[Any]]


def samples(ranges: Mapping[str, Range], n: int, seed: int = 0) -> List[Overrides]:
    """n random variants. Each range is ``(lo, hi)`` (uniform), ``(lo, hi, "log")`` (log-uniform,
    lo > 0), or ``(lo, hi, "int")`` (uniform integer, both ends included). The same seed gives
    the same variants on every machine (Python's Mersenne Twister, one draw per key in order)."""
    if n < 0:
        raise ValueError("the number of samples must be >= 0")
    rng = random.Random(seed)
    out: List[Overrides] = []
    spec = {k: _check_range(k, r) for k, r in ranges.items()}
    for _ in range(n):
        v: Overrides = {}
        for k, (lo, hi, kind) in spec.items():
            if kind == "log":
                v[k] = math.exp(rng.uniform(math.log(lo), math.log(hi)))
            elif kind == "int":
                v[k] = rng.randint(int(lo), int(hi))
            else:
                v[k] = rng.uniform(lo, hi)
        out.append(v)
    return out


def _check_range(key: str, r: Range) -> Tuple[float, float, str]:
    if len(r) not in (2, 3):
        raise ValueError(f"range of {key!r}: expected (lo, hi) or (lo, hi, kind), got {r!r}")
    lo, hi = float(r[0]), float(r[1])
    kind = str(r[2]) if len(r) == 3 else "uniform"
    if kind not in ("uniform", "log", "int"):
        raise ValueError(f"range of {key!r}: kind must be uniform, log or int, not {kind!r}")
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise ValueError(f"range of {key!r}: need finite lo <= hi, got {r!r}")
    if kind == "log" and lo <= 0:
        raise ValueError(f"range of {key!r}: a log-uniform range needs lo > 0")
    return lo, hi, kind


def parse_value(text: str) -> Any:
    """One value given on the command line: JSON if it parses (1e6, true, [0,1,0]), otherwise
    the text as a string (symplectic_euler), as ``defsim run --set`` reads it."""
    try:
        return json.loads(text)
    except ValueError:
        return text


def parse_grid_arg(arg: str) -> Tuple[str, List[Any]]:
    """``KEY=V1,V2,...`` as (key, values). Values that are JSON arrays keep their commas when
    written in brackets: ``world.gravity=[0,-9.81,0],[0,0,0]``."""
    key, sep, rest = arg.partition("=")
    if not sep or not key or not rest:
        raise ValueError(f"--grid {arg!r}: expected KEY=V1,V2,...")
    values, depth, cur = [], 0, ""
    for ch in rest:
        if ch == "," and depth == 0:
            values.append(cur)
            cur = ""
            continue
        depth += ch in "[{"
        depth -= ch in "]}"
        cur += ch
    values.append(cur)
    if any(not v for v in values):
        raise ValueError(f"--grid {arg!r}: empty value")
    return key, [parse_value(v) for v in values]


def dedupe(variants: Iterable[Mapping[str, Any]]) -> List[Tuple[str, Overrides]]:
    """(id, overrides) for each distinct variant, in the given order."""
    seen, out = set(), []
    for v in variants:
        ov = {str(k): _plain(x) for k, x in v.items()}
        vid = variant_id(ov)
        if vid not in seen:
            seen.add(vid)
            out.append((vid, ov))
    return out
