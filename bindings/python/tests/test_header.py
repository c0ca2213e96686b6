# SPDX-License-Identifier: MIT
"""The header as the package reads it: preprocessing, cffi declarations, enums and structs that
the Python side mirrors, and the version checks."""
from __future__ import annotations

import dataclasses
import os
import re

import pytest

import defsim
from defsim import _native
from defsim._cheader import HeaderError, eval_int, preprocess

HERE = os.path.dirname(os.path.abspath(__file__))


def _header_text() -> str:
    # The header the package found (first defsim/defsim.h on its include path).
    for d in _native._include_path(_native.library_path):
        p = os.path.join(d, "defsim", "defsim.h")
        if os.path.isfile(p):
            with open(p, encoding="utf-8") as f:
                return f.read()
    raise AssertionError("defsim.h not found")


def test_every_public_function_is_declared_and_exported() -> None:
    names = re.findall(r"DEFSIM_API\s+[^;(]*?\b(defsim_\w+)\s*\(", _header_text())
    assert len(names) >= 25
    for name in names:
        assert re.search(r"\b%s\s*\(" % name, _native.declarations), name
        assert callable(getattr(_native.lib, name)), name


def test_status_enum_matches_header() -> None:
    elements = _native.ffi.typeof("defsim_status").relements
    assert {k[len("DEFSIM_"):].replace("ERR_", ""): v for k, v in elements.items()} == {
        s.name: int(s) for s in defsim.Status}


def test_model_and_projection_enums_match_header() -> None:
    models = _native.ffi.typeof("defsim_model").relements
    assert {k[len("DEFSIM_MODEL_"):]: v for k, v in models.items()} == {
        m.name: int(m) for m in defsim.Model}
    proj = _native.ffi.typeof("defsim_projection").relements
    assert {k[len("DEFSIM_PROJECTION_"):]: v for k, v in proj.items()} == {
        p.name: int(p) for p in defsim.Projection}


def test_pass_flags_match_header() -> None:
    for p in defsim.Pass:
        assert getattr(_native.lib, "DEFSIM_PASS_" + p.name) == int(p)
    declared = set(re.findall(r"\bDEFSIM_PASS_(\w+)\s*=", _native.declarations))
    assert declared == {p.name for p in defsim.Pass}


def test_stats_and_energy_mirror_the_structs() -> None:
    # When a field is appended to defsim_stats, Stats must learn it: this fails until it does.
    stats_fields = [f[0] for f in _native.ffi.typeof("defsim_stats").fields if f[0] != "size"]
    # Stats ends with `counters`, the backend's counters by name (not a field of the struct).
    assert [f.name for f in dataclasses.fields(defsim.Stats)] == stats_fields + ["counters"]
    energy_fields = [f[0] for f in _native.ffi.typeof("defsim_energy").fields]
    assert list(defsim.Energy._fields) == energy_fields


def test_versions() -> None:
    assert defsim.library_version() == defsim.header_version()
    major, minor, patch = defsim.header_version()
    assert defsim.__version__ == f"{major}.{minor}.{patch}"
    pyproject = os.path.join(HERE, os.pardir, "pyproject.toml")
    if os.path.isfile(pyproject):   # the source tree, not an installed copy
        with open(pyproject, encoding="utf-8") as f:
            m = re.search(r'^version\s*=\s*"([^"]+)"', f.read(), re.M)
        assert m and m.group(1) == defsim.__version__


# ---- the preprocessor on its own -------------------------------------------------------------

def _write(tmp_path, name: str, text: str) -> str:
    p = tmp_path / name
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(text)
    return str(p)


def test_preprocess_conditionals_includes_and_macros(tmp_path) -> None:
    _write(tmp_path, "inc/sub/v.h", "#define V_NUM (2 * 10000 + 3u)\n#define EMPTY\n")
    main = _write(tmp_path, "inc/main.h", r"""
/* a block comment
   over lines */ // and a line comment
#include <stdint.h>
#include "sub/v.h"
#if defined(_WIN32) && !defined(STATIC)
#  define API __declspec(dllexport)
#elif defined(__GNUC__)
#  define API __attribute__((visibility("default")))
#else
#  define API
#endif
#ifdef __cplusplus
extern "C" {
#endif
#if V_NUM >= 20003 && (1 << 2) == 4
API int32_t yes(void); // kept
#else
int no(void);
#endif
#ifndef EMPTY
int no2(void);
#endif
#if 0
#  if 1
int no3(void);
#  endif
#elif 0x10 == 020
int yes2(const char *s);
#endif
#undef EMPTY
#ifndef EMPTY
int yes3(void);
#endif
#ifdef __cplusplus
}
#endif
""")
    text, macros = preprocess(main, [str(tmp_path / "inc")])
    assert re.findall(r"\b(\w+)\(", text) == ["yes", "yes2", "yes3"]
    assert "extern" not in text and "API" not in text and "/*" not in text
    assert eval_int(macros["V_NUM"]) == 20003
    assert "EMPTY" not in macros
    gnu, _ = preprocess(main, [str(tmp_path / "inc")], predefined={"__GNUC__": "4"})
    assert "visibility" in gnu


@pytest.mark.parametrize("body", [
    "#define F(x) (x)\n",
    "#if 1\n",
    "#endif\n",
    "#include \"missing.h\"\n",
    "#error stop\n",
    "#warning odd\n",
    "/* open\n",
])
def test_preprocess_rejects(tmp_path, body: str) -> None:
    with pytest.raises(HeaderError):
        preprocess(_write(tmp_path, "h.h", body), [str(tmp_path)])


def test_eval_int() -> None:
    assert eval_int("(0 * 10000 + 1 * 100 + 0)") == 100
    assert eval_int("1u << 10") == 1024
    assert eval_int("0x1F | 010") == 31
    assert eval_int("!0 && 3 > 2 || 0") == 1
    assert eval_int("7 / 2") == 3
    with pytest.raises(HeaderError):
        eval_int("__import__('os')")
