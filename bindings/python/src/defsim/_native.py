# SPDX-License-Identifier: MIT
"""Finds libdefsim, the cffi declarations generated for its header, and opens the library.

Nothing here needs a C compiler or parses a header: the declarations were generated when the
package was built (``bindings/python/build_ffi.py``: the compiler's preprocessor, cffi's
out-of-line ABI mode, and a C file of static assertions that the build compiles, so that cffi's
layout of every struct, enum and function was checked against the compiler's then). The
library is opened with ``ffi.dlopen``; functions are looked up lazily, so a function that the
header declares but the library lacks fails only when called.

Where the declarations come from (the module ``_defsim_ffi``), first match wins:
  1. the package (``defsim/_defsim_ffi.py``, put there by pip install and the wheel);
  2. ``python/_defsim_ffi.py`` beside the library that ``DEFSIM_LIBRARY`` names (a build tree:
     ``DEFSIM_LIBRARY=build/libdefsim.so`` alone is enough);
  3. ``_defsim_ffi`` on ``sys.path`` (a build tree's ``<build>/python``, for a library found
     on the loader's path).
Where the library comes from, first match wins:
  1. ``DEFSIM_LIBRARY``: a path to the shared library (an error if it cannot be opened);
  2. the library bundled in the package (``defsim/libdefsim.so.<major>``, put there by pip install);
  3. the dynamic loader's search path (LD_LIBRARY_PATH, its cache, the default directories),
     as ``libdefsim.so.<major>`` (the SONAME), then ``libdefsim.so``.
"""
from __future__ import annotations

import importlib
import importlib.util
import os
import sys
from types import ModuleType
from typing import Any, List, Optional, Tuple

_PKG_DIR = os.path.dirname(os.path.abspath(__file__))
_FFI_MODULE = "_defsim_ffi"


def _bundled_library() -> Optional[str]:
    # A wheel holds libdefsim under its SONAME (libdefsim.so.<major>), which the bundled
    # libdefsim_scene names as its dependency; a development install may hold libdefsim.so.
    if sys.platform in ("darwin", "win32"):
        names = ["libdefsim.dylib" if sys.platform == "darwin" else "defsim.dll"]
    else:
        names = sorted(n for n in os.listdir(_PKG_DIR) if n.startswith("libdefsim.so."))
        names.append("libdefsim.so")
    for name in names:
        path = os.path.join(_PKG_DIR, name)
        if os.path.isfile(path):
            return path
    return None


def _system_names(major: int) -> List[str]:
    """Names for the dynamic loader, which searches LD_LIBRARY_PATH, its cache and the default
    directories: the SONAME of this major version first."""
    if sys.platform == "darwin":
        return [f"libdefsim.{major}.dylib", "libdefsim.dylib"]
    if sys.platform == "win32":
        return ["defsim.dll"]
    return [f"libdefsim.so.{major}", "libdefsim.so"]


def _load_file(path: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(_FFI_MODULE, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules[_FFI_MODULE] = module
    return module


def _declarations(explicit: Optional[str]) -> ModuleType:
    """The generated module of cffi declarations (see the module's docstring for the order)."""
    tried = [os.path.join(_PKG_DIR, _FFI_MODULE + ".py")]
    if os.path.isfile(tried[0]):
        module = importlib.import_module("." + _FFI_MODULE, __package__)
    else:
        module = None
        if explicit and os.path.sep in explicit:
            path = os.path.join(os.path.dirname(os.path.abspath(explicit)), "python",
                                _FFI_MODULE + ".py")
            tried.append(path)
            if os.path.isfile(path):
                module = _load_file(path)
        if module is None:
            tried.append(f"{_FFI_MODULE} on sys.path")
            if importlib.util.find_spec(_FFI_MODULE) is not None:
                module = importlib.import_module(_FFI_MODULE)
    if module is None:
        raise ImportError("defsim: the cffi declarations generated at build time were not found "
                          "(tried " + ", ".join(tried) + "): install the package (pip install "
                          "./bindings/python), or build the project with its Python binding "
                          "(cmake --build build) and set DEFSIM_LIBRARY=build/libdefsim.so or "
                          "put build/python on PYTHONPATH")
    if not all(hasattr(module, a) for a in ("ffi", "HEADER_VERSION_NUMBER", "CDEF")):
        raise ImportError(f"defsim: {getattr(module, '__file__', module)} is not the declarations "
                          "module that bindings/python/build_ffi.py writes")
    return module


def _open() -> Tuple[Any, Any, str, str, int, str]:
    explicit = os.environ.get("DEFSIM_LIBRARY") or None
    decl = _declarations(explicit)
    ffi = decl.ffi
    header_version = int(decl.HEADER_VERSION_NUMBER)
    first = explicit or _bundled_library()
    candidates = [explicit] if explicit else (
        ([first] if first else []) + _system_names(header_version // 10000))
    errors = []
    for cand in candidates:
        try:
            lib = ffi.dlopen(cand)
        except OSError as exc:
            if explicit:
                raise ImportError(f"defsim: DEFSIM_LIBRARY={cand} cannot be opened: {exc}") from exc
            errors.append(f"{cand}: {exc}")
            continue
        break
    else:
        raise ImportError("defsim: libdefsim not found (not bundled with the package, not in "
                          "the loader's search path, DEFSIM_LIBRARY not set): " + "; ".join(errors))
    try:
        lib_version = int(lib.defsim_version_number())
    except AttributeError as exc:
        raise ImportError(f"defsim: {cand} does not export defsim_version_number") from exc
    # ABI is stable within a major version, and fields and functions are only appended: the
    # library must be of the header's major version and at least as new.
    if lib_version // 10000 != header_version // 10000 or lib_version < header_version:
        raise ImportError(
            f"defsim: library {cand} is version {_fmt(lib_version)}, but the package was built "
            f"for {_fmt(header_version)} (same major version, library at least as new, needed)")
    return ffi, lib, cand, decl.HEADER_VERSION_STRING, header_version, decl.CDEF


def _fmt(number: int) -> str:
    return f"{number // 10000}.{number // 100 % 100}.{number % 100}"


ffi, lib, library_path, header_version_string, header_version_number, declarations = _open()


def bundled_module_dir() -> Optional[str]:
    """The directory of backend modules bundled with the package, or None: ``defsim/`` beside
    the bundled libdefsim (``<libdir>/defsim``, where the core also looks by itself)."""
    d = os.path.join(_PKG_DIR, "defsim")
    return d if os.path.isdir(d) else None


_extra: dict = {}


def open_extra(name: str) -> Any:
    """Opens one of the optional libraries over the tools' code, whose headers the generated
    declarations include: "scene" (libdefsim_scene, include/defsim/scene.h: scene files and VTK
    frames), "render" (libdefsim_render, include/defsim/render.h: the OSMesa renderer) or
    "view" (libdefsim_view, include/defsim/view.h: the live viewer). Searched in
    ``DEFSIM_<NAME>_LIBRARY`` (``DEFSIM_SCENE_LIBRARY``, ...), beside the loaded
    libdefsim (a build tree, an install prefix, the package), then the loader's path. Raises
    OSError with every place tried when it is not there. The result is cached."""
    if name in _extra:
        return _extra[name]
    env = os.environ.get(f"DEFSIM_{name.upper()}_LIBRARY") or None
    file = f"libdefsim_{name}.so" if sys.platform != "darwin" else f"libdefsim_{name}.dylib"
    here = os.path.dirname(os.path.abspath(library_path)) if os.path.sep in library_path else None
    candidates = [env] if env else [os.path.join(d, file) for d in (here, _PKG_DIR) if d] + [file]
    errors = []
    for cand in candidates:
        try:
            extra = ffi.dlopen(cand)
            break
        except OSError as exc:
            errors.append(f"{cand}: {exc}")
    else:
        raise OSError(f"defsim: libdefsim_{name} not found: " + "; ".join(errors))
    _extra[name] = extra
    return extra


def _add_bundled_modules() -> None:
    # The core reads DEFSIM_BACKEND_PATH each time it looks for a module, so appending the
    # bundled directory here (after any directory the user set) makes pip-installed modules
    # load without overriding the user's own choice. Only for the bundled library: modules
    # are built together with it.
    d = bundled_module_dir()
    if d is None or os.path.dirname(os.path.abspath(library_path)) != _PKG_DIR:
        return
    parts = [p for p in os.environ.get("DEFSIM_BACKEND_PATH", "").split(":") if p]
    if d not in parts:
        os.environ["DEFSIM_BACKEND_PATH"] = ":".join(parts + [d])


_add_bundled_modules()
