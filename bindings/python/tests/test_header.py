# SPDX-License-Identifier: MIT
"""The header as the package reads it: the cffi declarations generated at build time
(build_ffi.py) against the header's text, enums and structs that the Python side mirrors, the
version checks, and the build-time ABI check failing when cffi and the compiler disagree."""
from __future__ import annotations

import dataclasses
import os
import re

import pytest

import defsim
from defsim import _native

HERE = os.path.dirname(os.path.abspath(__file__))
PACKAGE = os.path.dirname(HERE)
INCLUDE = os.path.join(PACKAGE, os.pardir, os.pardir, "include")


def _header_text(name: str = "defsim.h") -> str:
    # The source tree's header (the one the declarations were generated from).
    p = os.path.join(INCLUDE, "defsim", name)
    if not os.path.isfile(p):
        pytest.skip("not a source tree: no include/defsim beside the package")
    with open(p, encoding="utf-8") as f:
        return f.read()


def test_every_public_function_is_declared_and_exported() -> None:
    names = re.findall(r"DEFSIM_API\s+[^;(]*?\b(defsim_\w+)\s*\(", _header_text())
    assert len(names) >= 25
    for name in names:
        assert re.search(r"\b%s\s*\(" % name, _native.declarations), name
        assert callable(getattr(_native.lib, name)), name
    # The scene, render and view headers are declared too (their libraries are opened on first
    # use).
    for header in ("scene.h", "render.h", "view.h"):
        for name in re.findall(r"DEFSIM_API\s+[^;(]*?\b(defsim_\w+)\s*\(", _header_text(header)):
            assert re.search(r"\b%s\s*\(" % name, _native.declarations), name


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




# ---- the build-time ABI check (build_ffi.py) ------------------------------------------------

_CHECKED_HEADER = r"""
#include <stdint.h>
#include "t/version.h"
typedef struct t_pair {
    uint32_t size;
#ifdef __GNUC__          /* the compiler sees this; cffi's preprocessing (-undef) does not */
    int64_t count;
#else
    int32_t count;
#endif
    double value[2];
} t_pair;
typedef enum t_kind { T_A = 1, T_B = 1 << 3 } t_kind;
#ifdef __GNUC__
int64_t t_get(const t_pair *p);
#else
int32_t t_get(const t_pair *p);
#endif
int32_t t_set(t_pair *p, t_kind k, const double v[2]);
"""


def _abi_check(tmp_path, header: str):
    """Runs build_ffi.py on `header` (as t/t.h) and compiles its check with the C compiler:
    (the generated module's ffi, the compiler's result)."""
    import importlib.util
    import shutil
    import subprocess
    import sys
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    script = os.path.join(PACKAGE, "build_ffi.py")
    if cc is None or not os.path.isfile(script):
        pytest.skip("needs a C compiler and the source tree's build_ffi.py")
    inc = tmp_path / "inc" / "t"
    inc.mkdir(parents=True)
    (inc / "version.h").write_text('#define DEFSIM_VERSION_NUMBER (1 * 10000 + 2 * 100 + 3)\n'
                                   '#define DEFSIM_VERSION_STRING "1.2.3"\n')
    (inc / "t.h").write_text(header)
    module, check = tmp_path / "gen" / "_t_ffi.py", tmp_path / "gen" / "check.c"
    subprocess.run([sys.executable, script, "--cc", cc, "-I", str(tmp_path / "inc"),
                    "--version", "1.2.3", "--module", str(module), "--check", str(check),
                    "t/t.h"], check=True, timeout=120)
    spec = importlib.util.spec_from_file_location("_t_ffi", module)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.HEADER_VERSION_NUMBER == 10203 and mod.HEADER_VERSION_STRING == "1.2.3"
    r = subprocess.run([cc, "-std=gnu11", "-c", "-I", str(tmp_path / "inc"), str(check), "-o",
                        str(tmp_path / "check.o")], capture_output=True, text=True, timeout=120)
    return mod.ffi, r


def test_abi_check_passes_when_cffi_and_the_compiler_agree(tmp_path) -> None:
    agree = _CHECKED_HEADER.replace("#ifdef __GNUC__", "#if 0")
    ffi, r = _abi_check(tmp_path, agree)
    assert r.returncode == 0, r.stderr
    assert ffi.sizeof("t_pair") == 24 and ffi.offsetof("t_pair", "value") == 8
    assert ffi.typeof("t_kind").relements == {"T_A": 1, "T_B": 8}


def test_abi_check_fails_the_build_when_they_disagree(tmp_path) -> None:
    # cffi reads `int32_t count` and `int32_t t_get(...)` where the compiler sees int64_t: the
    # check's compile fails and names each difference.
    ffi, r = _abi_check(tmp_path, _CHECKED_HEADER)
    assert ffi.sizeof("t_pair") == 24   # cffi's (wrong) view: the compiler says 32
    assert r.returncode != 0
    for what in ("sizeof(t_pair)", "offsetof(t_pair.count)", "offsetof(t_pair.value)",
                 "the type of t_pair.count",
                 "the type of t_get"):
        assert f"cffi and the C compiler disagree: {what}" in r.stderr, what
    for fine in ("offsetof(t_pair.size)", "the type of t_set", "T_B == 8"):
        assert f"disagree: {fine}\"" not in r.stderr, fine
