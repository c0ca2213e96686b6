# SPDX-License-Identifier: MIT
"""``python -m defsim.scenes``: the shipped scenes' names; ``python -m defsim.scenes NAME``: the
path of one (exit status 1, with the closest names, when there is no such scene)."""
import sys

from . import names, path

if len(sys.argv) == 1:
    print("\n".join(names()))
    sys.exit(0)
try:
    print("\n".join(path(n) for n in sys.argv[1:]))
except FileNotFoundError as exc:
    print(exc, file=sys.stderr)
    sys.exit(1)
