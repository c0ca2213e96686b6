# SPDX-License-Identifier: MIT
"""Finds libdefsim and its header, declares the header to cffi (ABI mode) and opens the library.

Nothing here needs a C compiler: the header is preprocessed in pure Python (_cheader.py) and
handed to ``cffi.FFI.cdef``; the library is opened with ``ffi.dlopen``. Functions are looked up
lazily, so a function that the header declares but the library lacks fails only when called.

Where the library comes from, first match wins:
  1. ``DEFSIM_LIBRARY``: a path to the shared library (an error if it cannot be opened);
  2. the library bundled in the package (``defsim/libdefsim.so``, put there by pip install);
  3. the dynamic loader's search path (LD_LIBRARY_PATH, its cache, the default directories),
     as ``libdefsim.so.<major>`` (the SONAME), then ``libdefsim.so``.
Where the header comes from: the directories in ``DEFSIM_INCLUDE_PATH`` (``os.pathsep``-separated),
then the package's bundled ``defsim/include``, then ``include`` and ``../include`` beside the
library, then /usr/local/include and /usr/include. ``defsim/version.h`` is found the same way.
"""
from __future__ import annotations

import os
import sys
from typing import Any, List, Optional, Tuple

import cffi

from ._cheader import HeaderError, eval_int, preprocess

_PKG_DIR = os.path.dirname(os.path.abspath(__file__))


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


def _include_path(library: Optional[str]) -> List[str]:
    dirs = [d for d in os.environ.get("DEFSIM_INCLUDE_PATH", "").split(os.pathsep) if d]
    dirs.append(os.path.join(_PKG_DIR, "include"))
    if library and os.path.sep in library:
        libdir = os.path.dirname(os.path.abspath(library))
        dirs += [os.path.join(libdir, "include"), os.path.join(os.path.dirname(libdir), "include")]
    dirs += ["/usr/local/include", "/usr/include"]
    return dirs


def _open() -> Tuple[cffi.FFI, Any, str, str, int, str]:
    explicit = os.environ.get("DEFSIM_LIBRARY") or None
    first = explicit or _bundled_library()
    # The header that matches the library is searched beside it first (a build tree or an
    # install prefix), after DEFSIM_INCLUDE_PATH and the bundled copy.
    include = _include_path(first)
    try:
        decls, macros = preprocess(os.path.join("defsim", "defsim.h"), include)
        header_version = eval_int(macros["DEFSIM_VERSION_NUMBER"])
        version_string = macros.get("DEFSIM_VERSION_STRING", '""').strip('"')
    except (HeaderError, KeyError, OSError) as exc:
        raise ImportError(f"defsim: cannot read the public header defsim/defsim.h "
                          f"(searched {include}): {exc}") from exc
    candidates = [explicit] if explicit else (
        ([first] if first else []) + _system_names(header_version // 10000))
    ffi = cffi.FFI()
    try:
        ffi.cdef(decls)
    except cffi.CDefError as exc:
        raise ImportError(f"defsim: cffi cannot parse defsim.h: {exc}") from exc
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
    return ffi, lib, cand, version_string, header_version, decls


def _fmt(number: int) -> str:
    return f"{number // 10000}.{number // 100 % 100}.{number % 100}"


ffi, lib, library_path, header_version_string, header_version_number, declarations = _open()


def bundled_module_dir() -> Optional[str]:
    """The directory of backend modules bundled with the package, or None: ``defsim/`` beside
    the bundled libdefsim (``<libdir>/defsim``, where the core also looks by itself)."""
    d = os.path.join(_PKG_DIR, "defsim")
    return d if os.path.isdir(d) else None


_extra: dict = {}
_declared: set = set()


def open_extra(name: str) -> Any:
    """Opens one of the optional libraries over the tools' code, declaring its header to the
    same ffi: "scene" (libdefsim_scene, include/defsim/scene.h: scene files and VTK frames) or
    "render" (libdefsim_render, include/defsim/render.h: the OSMesa renderer). Searched in
    ``DEFSIM_SCENE_LIBRARY`` / ``DEFSIM_RENDER_LIBRARY``, beside the loaded libdefsim (a
    build tree, an install prefix, the package), then the loader's path. Raises OSError with
    every place tried when it is not there. The result is cached."""
    if name in _extra:
        return _extra[name]
    env = os.environ.get(f"DEFSIM_{name.upper()}_LIBRARY") or None
    file = f"libdefsim_{name}.so" if sys.platform != "darwin" else f"libdefsim_{name}.dylib"
    here = os.path.dirname(os.path.abspath(library_path)) if os.path.sep in library_path else None
    candidates = [env] if env else [os.path.join(d, file) for d in (here, _PKG_DIR) if d] + [file]
    header = os.path.join("defsim", f"{name}.h")
    include = _include_path(library_path)
    try:
        # defsim.h is declared already: its include guard and DEFSIM_API are predefined so that
        # only the extra header's own declarations reach cdef.
        decls, _ = preprocess(header, include, {"DEFSIM_DEFSIM_H": "1", "DEFSIM_API": ""})
    except (HeaderError, OSError) as exc:
        raise OSError(f"defsim: cannot read {header} (searched {include}): {exc}") from exc
    if name not in _declared:
        ffi.cdef(decls)
        _declared.add(name)
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
