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


def _declarations_file() -> str:
    """The generated declarations module the package loaded (build_ffi.py's output)."""
    return sys.modules[_native._FFI_MODULE if _native._FFI_MODULE in sys.modules
                       else f"defsim.{_native._FFI_MODULE}"].__file__


def _pythonpath(*first: str) -> str:
    rest = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    return os.pathsep.join(list(first) + rest)


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
    if os.path.isfile(os.path.join(_native._PKG_DIR, _native._FFI_MODULE + ".py")):
        pytest.skip("the installed package's own declarations come first")
    if os.path.sep not in _native.library_path:
        pytest.skip("needs the loaded library's path")
    # A copy of the library with, beside it, declarations that claim another header version.
    with open(_declarations_file(), encoding="utf-8") as f:
        text = f.read()
    n = _native.header_version_number + delta
    text, count = re.subn(r"^HEADER_VERSION_NUMBER = .*$", f"HEADER_VERSION_NUMBER = {n}", text,
                          flags=re.M)
    assert count == 1
    (tmp_path / "python").mkdir()
    (tmp_path / "python" / (_native._FFI_MODULE + ".py")).write_text(text)
    lib = tmp_path / os.path.basename(_native.library_path)
    shutil.copy(_native.library_path, lib)
    probe = PROBE.replace("sys.exit(0)", "sys.exit(0 if sys.modules['_defsim_ffi']"
                          ".HEADER_VERSION_NUMBER == %d else 4)" % n)
    rc = _import_rc({"DEFSIM_LIBRARY": str(lib)}, probe)
    assert rc == (0 if ok else 3)


def test_declarations_beside_the_library_or_a_clear_error(tmp_path) -> None:
    # A build tree: DEFSIM_LIBRARY=<build>/libdefsim.so finds <build>/python/_defsim_ffi.py
    # with only the sources on PYTHONPATH; without declarations, import fails cleanly.
    lib = os.environ.get("DEFSIM_LIBRARY", "")
    beside = os.path.join(os.path.dirname(lib), "python", _native._FFI_MODULE + ".py")
    if not os.path.isfile(beside) or os.path.isfile(
            os.path.join(_native._PKG_DIR, _native._FFI_MODULE + ".py")):
        pytest.skip("needs a build tree's library named by DEFSIM_LIBRARY, and no bundled one")
    src = os.path.dirname(_native._PKG_DIR)
    probe = ("import sys, defsim; sys.exit(0 if sys.modules['_defsim_ffi'].__file__ == "
             f"{beside!r} else 4)")
    assert _import_rc({"PYTHONPATH": src}, probe) == 0
    fake = tmp_path / "libdefsim.so"
    fake.write_text("no declarations beside it")
    probe = """
import sys
try:
    import defsim
except ImportError as e:
    sys.exit(3 if "declarations generated at build time were not found" in str(e) else 5)
sys.exit(0)
"""
    assert _import_rc({"PYTHONPATH": src, "DEFSIM_LIBRARY": str(fake)}, probe) == 3


def test_a_stray_declarations_module_is_not_taken(tmp_path) -> None:
    # A file named _defsim_ffi.py in the script's folder (or anywhere on sys.path) is not taken
    # over the declarations beside DEFSIM_LIBRARY, and is refused where it would be.
    lib = os.environ.get("DEFSIM_LIBRARY", "")
    beside = os.path.join(os.path.dirname(lib), "python", _native._FFI_MODULE + ".py")
    if not os.path.isfile(beside):
        pytest.skip("needs a build tree's library named by DEFSIM_LIBRARY")
    (tmp_path / (_native._FFI_MODULE + ".py")).write_text("ffi = None\n")
    probe = ("import sys, defsim; sys.exit(0 if sys.modules['_defsim_ffi'].__file__ == "
             f"{beside!r} else 4)")
    assert _import_rc({"PYTHONPATH": _pythonpath(str(tmp_path))}, probe) == 0
    if ctypes.util.find_library("defsim") is None:
        assert _import_rc({"PYTHONPATH": _pythonpath(str(tmp_path)), "DEFSIM_LIBRARY": None,
                           "LD_LIBRARY_PATH": os.path.dirname(os.path.abspath(lib))}) == 3


def test_library_from_the_loader_search_path() -> None:
    # Without DEFSIM_LIBRARY and without a bundled copy, the package asks the dynamic loader
    # for the SONAME, libdefsim.so.<major>, which LD_LIBRARY_PATH can point at.
    lib = os.environ.get("DEFSIM_LIBRARY", "")
    soname = f"libdefsim.so.{defsim.header_version()[0]}"
    if (_native._bundled_library() or not sys.platform.startswith("linux")
            or not os.path.isfile(os.path.join(os.path.dirname(lib), soname))):
        pytest.skip("needs a build tree's library named by DEFSIM_LIBRARY, and no bundled one")
    probe = f"import sys, defsim; sys.exit(0 if defsim.library_path == {soname!r} else 4)"
    # The declarations from sys.path (the build tree's python/ folder).
    gen = os.path.dirname(_declarations_file())
    assert _import_rc({"DEFSIM_LIBRARY": None, "PYTHONPATH": _pythonpath(gen),
                       "LD_LIBRARY_PATH": os.path.dirname(os.path.abspath(lib))}, probe) == 0
    # And with nothing to find, the import fails cleanly (unless one is installed system-wide).
    if ctypes.util.find_library("defsim") is None:
        assert _import_rc({"DEFSIM_LIBRARY": None, "PYTHONPATH": _pythonpath(gen),
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
