# SPDX-License-Identifier: MIT
"""How the package finds and checks the library: each case imports defsim in a fresh interpreter
with a changed environment and reports the outcome by exit code."""
from __future__ import annotations

import ctypes.util
import os
import re
import shutil
import subprocess
import sys

import pytest

import defsim
from defsim import _native

PROBE = """
import sys
try:
    import defsim
except ImportError:
    sys.exit(3)
sys.exit(0)
"""


def _import_rc(env_changes: dict, probe: str = PROBE) -> int:
    env = dict(os.environ)
    for k, v in env_changes.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    return subprocess.run([sys.executable, "-c", probe], env=env, timeout=60).returncode


def _header_dirs():
    """Directories holding defsim/defsim.h and defsim/version.h, as the package found them."""
    found = {}
    for d in _native._include_path(_native.library_path):
        for name in ("defsim.h", "version.h"):
            if name not in found and os.path.isfile(os.path.join(d, "defsim", name)):
                found[name] = os.path.join(d, "defsim", name)
    return found


def test_import_with_the_current_environment_works() -> None:
    assert _import_rc({}) == 0


def test_missing_library_fails_import(tmp_path) -> None:
    assert _import_rc({"DEFSIM_LIBRARY": str(tmp_path / "libnothere.so")}) == 3


def test_not_a_library_fails_import(tmp_path) -> None:
    fake = tmp_path / "libdefsim.so"
    fake.write_text("not an ELF file")
    assert _import_rc({"DEFSIM_LIBRARY": str(fake)}) == 3


@pytest.mark.parametrize("delta,ok", [
    (10000, False),   # header of the next major version: refused
    (100, False),     # header newer than the library: refused
    (-100, True),     # an older header of the same major: the newer library serves it
])
def test_version_check(tmp_path, delta: int, ok: bool) -> None:
    if delta < 0 and defsim.header_version()[1] == 0:
        pytest.skip("no older minor version of this major")
    src = _header_dirs()
    inc = tmp_path / "inc" / "defsim"
    inc.mkdir(parents=True)
    shutil.copy(src["defsim.h"], inc / "defsim.h")
    with open(src["version.h"], encoding="utf-8") as f:
        text = f.read()
    n = _native.header_version_number + delta
    text = re.sub(r"#define DEFSIM_VERSION_NUMBER .*",
                  f"#define DEFSIM_VERSION_NUMBER ({n})", text)
    (inc / "version.h").write_text(text)
    rc = _import_rc({"DEFSIM_INCLUDE_PATH": str(tmp_path / "inc"),
                     "DEFSIM_LIBRARY": os.path.abspath(_native.library_path)
                     if os.path.sep in _native.library_path else _native.library_path})
    assert rc == (0 if ok else 3)


def test_library_from_the_loader_search_path() -> None:
    # Without DEFSIM_LIBRARY and without a bundled copy, the package asks the dynamic loader
    # for the SONAME, libdefsim.so.<major>, which LD_LIBRARY_PATH can point at.
    lib = os.environ.get("DEFSIM_LIBRARY", "")
    soname = f"libdefsim.so.{defsim.header_version()[0]}"
    if (_native._bundled_library() or not sys.platform.startswith("linux")
            or not os.path.isfile(os.path.join(os.path.dirname(lib), soname))):
        pytest.skip("needs a build tree's library named by DEFSIM_LIBRARY, and no bundled one")
    probe = f"import sys, defsim; sys.exit(0 if defsim.library_path == {soname!r} else 4)"
    headers = _header_dirs()
    inc = os.pathsep.join(os.path.dirname(os.path.dirname(h)) for h in headers.values())
    assert _import_rc({"DEFSIM_LIBRARY": None, "DEFSIM_INCLUDE_PATH": inc,
                       "LD_LIBRARY_PATH": os.path.dirname(os.path.abspath(lib))}, probe) == 0
    # And with nothing to find, the import fails cleanly (unless one is installed system-wide).
    if ctypes.util.find_library("defsim") is None:
        assert _import_rc({"DEFSIM_LIBRARY": None, "DEFSIM_INCLUDE_PATH": inc,
                           "LD_LIBRARY_PATH": None}) == 3


def test_bundled_modules_are_added_to_the_backend_path(tmp_path, monkeypatch) -> None:
    # Simulate an installed package: a library beside the package files and its modules in
    # defsim/ beside it (<libdir>/defsim, where the core also looks relative to itself).
    (tmp_path / "defsim").mkdir()
    monkeypatch.setattr(_native, "_PKG_DIR", str(tmp_path))
    monkeypatch.setattr(_native, "library_path", str(tmp_path / "libdefsim.so"))
    monkeypatch.setenv("DEFSIM_BACKEND_PATH", "/first:/second")
    _native._add_bundled_modules()
    assert os.environ["DEFSIM_BACKEND_PATH"] == f"/first:/second:{tmp_path / 'defsim'}"
    _native._add_bundled_modules()   # idempotent
    assert os.environ["DEFSIM_BACKEND_PATH"].split(":").count(str(tmp_path / "defsim")) == 1
    # A library from elsewhere does not get the bundled modules.
    monkeypatch.setattr(_native, "library_path", "/usr/lib/libdefsim.so")
    monkeypatch.setenv("DEFSIM_BACKEND_PATH", "/first")
    _native._add_bundled_modules()
    assert os.environ["DEFSIM_BACKEND_PATH"] == "/first"
