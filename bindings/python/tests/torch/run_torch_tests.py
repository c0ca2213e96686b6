# SPDX-License-Identifier: MIT
"""ctest test_python_torch: runs this folder's tests (defsim.autograd) when the Python running it
has torch, and exits 77 (ctest's SKIP_RETURN_CODE: reported as not run, never as a pass)
when it has not."""
import importlib.util
import os
import sys

if __name__ == "__main__":
    missing = [m for m in ("torch", "numpy", "cffi", "pytest")
               if importlib.util.find_spec(m) is None]
    if missing:
        print(f"test_python_torch not run: {sys.executable} has no {', '.join(missing)} "
              "(set DEFSIM_TORCH_PYTHON to a Python with torch: pip install torch)")
        sys.exit(77)
    import pytest
    here = os.path.dirname(os.path.abspath(__file__))
    sys.exit(pytest.main(["-q", "-rs", "-p", "no:cacheprovider", here]))
