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
# Every bundled backend module loads and steps (they sit in <dir of libdefsim>/defsim/).
modules = os.path.join(pkg, "defsim")
names = sorted(f[len("defsim_"):-len(".so")] for f in os.listdir(modules)
               if f.startswith("defsim_") and f.endswith(".so")) if os.path.isdir(modules) else []
for name in names:
    with defsim.World(name, gravity=(0, -9.81, 0)) as w:
        body = w.add_body(mesh, material=defsim.Material("corotated", youngs_modulus=1e5))
        w.pin(body, mesh.positions[:, 0] == 0)
        w.step(1e-3, steps=5)
        assert w.positions[:, 1].min() < 0, name

# defsim.io from the bundled libdefsim_scene: a frame written and, with meshio (the [io] extra),
# read back; a scene file from the repository, run for two frames.
if os.path.isfile(os.path.join(pkg, "libdefsim_scene.so")):
    import tempfile

    import defsim.io as dio
    with tempfile.TemporaryDirectory() as tmp, defsim.World() as w:
        w.add_body(mesh, material=defsim.Material("corotated", youngs_modulus=1e5))
        w.step(1e-3, steps=3)
        path = os.path.join(tmp, "f.vtu")
        dio.write_vtu(w, path)
        try:
            import meshio
            assert (meshio.read(path).points == w.positions).all()
            assert dio.read_mesh(path).tet_count == mesh.tet_count
            io_note = "defsim.io with meshio"
        except ImportError:
            io_note = "defsim.io without meshio"
        scenes = os.environ.get("DEFSIM_SCENES")
        if scenes:
            s = dio.load_scene(os.path.join(scenes, "cloth.json"), {"world.duration": 0.05})
            s.run(os.path.join(tmp, "scene"))
            assert len(os.listdir(os.path.join(tmp, "scene"))) == s.frames + 2
            io_note += ", scene run"
else:
    io_note = "no libdefsim_scene"
print(f"defsim {defsim.__version__} from {pkg}; bundled modules: {names or 'none'}; {io_note}; "
      f"python {sys.version.split()[0]}")
