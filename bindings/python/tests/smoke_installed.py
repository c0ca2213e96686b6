# SPDX-License-Identifier: MIT
"""Smoke test of a pip-installed defsim (run by run_pip_install_test.cmake in a fresh venv).

Checks that the package loaded the library and header bundled in it (not a build tree), and that
a short simulation gives the free-fall result that symplectic Euler must give exactly.
"""
import os
import sys

import numpy as np

import defsim

pkg = os.path.dirname(os.path.abspath(defsim.__file__))
assert "site-packages" in pkg, f"defsim imported from {pkg}, not from the virtual environment"
assert os.path.dirname(os.path.abspath(defsim.library_path)) == pkg, defsim.library_path
assert os.path.isfile(os.path.join(pkg, "include", "defsim", "defsim.h"))
assert defsim.library_version() == defsim.header_version()

# A single free vertex: after n symplectic Euler steps, v = n h g and
# y = y0 + h^2 g n (n + 1) / 2, exactly up to rounding.
g, h, n = -9.81, 1e-3, 100
with defsim.World("symplectic_euler", gravity=(0, g, 0)) as w:
    w.add_body([[0.0, 0.0, 0.0]], material=defsim.Material("spring", vertex_mass=1.0))
    w.step(h, steps=n)
    y = w.positions[0, 1]
    v = w.velocities[0, 1]
assert abs(v - n * h * g) < 1e-12, v
assert abs(y - h * h * g * n * (n + 1) / 2) < 1e-12, y

mesh = defsim.mesh_box((0, 0, 0), (1, 0.2, 0.2), cells=(5, 1, 1))
with defsim.World(gravity=(0, -9.81, 0)) as w:
    body = w.add_body(mesh, material=defsim.Material("corotated", youngs_modulus=1e5))
    w.pin(body, mesh.positions[:, 0] == 0)
    w.step(1e-3, steps=50)
    assert w.positions[:, 1].min() < 0
    assert np.all(w.positions[mesh.positions[:, 0] == 0] == mesh.positions[mesh.positions[:, 0] == 0])
modules = os.path.join(pkg, "modules")
print(f"defsim {defsim.__version__} from {pkg}; bundled modules: "
      f"{sorted(os.listdir(modules)) if os.path.isdir(modules) else 'none'}; python "
      f"{sys.version.split()[0]}")
