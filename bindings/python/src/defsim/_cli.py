# SPDX-License-Identifier: MIT
"""The `defsim` command (console entry point and ``python -m defsim``): the C `defsim` tool.

The wheel carries the native executable (``defsim/bin/defsim``, linked to the bundled
libdefsim, which finds the bundled backend modules beside itself), so ``defsim run SCENE``,
``defsim stress`` and ``defsim bench`` are the C tool's own, with no environment variable. This
module only finds it and replaces the Python process by it (``execv``): there is no second
implementation of the command line.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import List, Optional, Sequence

_PKG_DIR = Path(__file__).resolve().parent
_EXE = "defsim.exe" if sys.platform == "win32" else "defsim"


def bundled_defsim() -> Optional[str]:
    """The executable the package carries (``defsim/bin/defsim`` of a wheel), or None."""
    cand = _PKG_DIR / "bin" / _EXE
    return str(cand) if os.access(cand, os.X_OK) and cand.is_file() else None


def _is_this_entry_point(path: str) -> bool:
    # The console script pip writes for `defsim` is a Python file that calls main() below:
    # running it from main() would call itself forever.
    try:
        with open(path, "rb") as f:
            head = f.read(1024)
    except OSError:
        return False
    return head.startswith(b"#!") and b"defsim._cli" in head


def _source_builds() -> List[Path]:
    # bindings/python/src/defsim/_cli.py -> the repository root, whose build*/ folders a
    # development checkout may hold.
    root = _PKG_DIR.parents[3] if len(_PKG_DIR.parents) > 3 else None
    if root is None or not (root / "bindings" / "python").is_dir():
        return []
    return sorted(root.glob("build*"))


def find_defsim(exe: Optional[str] = None, *, option: Optional[str] = "exe=PATH") -> str:
    """The `defsim` executable: `exe` if given, else ``$DEFSIM_EXE``, else the one bundled in
    the package (a wheel), else `defsim` on PATH, else a build tree around this source checkout
    (``build*/bin/defsim``). `option` is how the caller's user passes `exe` (``exe=PATH`` from
    Python, ``--exe PATH`` on a command line; None: no such way), for the message. Raises
    FileNotFoundError."""
    for cand in (exe, os.environ.get("DEFSIM_EXE")):
        if cand:
            path = shutil.which(cand) or (cand if os.access(cand, os.X_OK) else None)
            if not path:
                raise FileNotFoundError(f"defsim executable {cand!r} not found or not executable")
            return os.path.abspath(path)
    bundled = bundled_defsim()
    if bundled:
        return bundled
    on_path = shutil.which(_EXE)
    if on_path and not _is_this_entry_point(on_path):
        return os.path.abspath(on_path)
    for build in _source_builds():
        cand = build / "bin" / _EXE
        if os.access(cand, os.X_OK):
            return str(cand)
    raise FileNotFoundError("no defsim executable: " + (f"pass {option}, " if option else "") +
                            "set DEFSIM_EXE, put defsim on PATH, install the wheel (it carries "
                            "one), or build the project (build/bin/defsim)")


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Runs the C `defsim` with `argv` (default: this process's arguments)."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        exe = find_defsim(option=None)
    except FileNotFoundError as exc:
        print(f"defsim: {exc}", file=sys.stderr)
        return 127
    sys.stdout.flush()
    sys.stderr.flush()
    if os.name == "posix" and argv is None:
        os.execv(exe, ["defsim"] + args)   # does not return
    return subprocess.call([exe] + args)
