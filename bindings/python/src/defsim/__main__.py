# SPDX-License-Identifier: MIT
"""``python -m defsim ARGS``: the C `defsim` tool (defsim._cli), as the `defsim` command."""
import sys

from ._cli import main

sys.exit(main())
