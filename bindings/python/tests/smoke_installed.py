# SPDX-License-Identifier: MIT
"""Smoke test of a pip-installed defsim (run by run_pip_install_test.cmake and wheel_test.py in
a fresh venv, with no DEFSIM_* variable).

Checks that the package loaded the library and declarations bundled in it (not a build tree),
that a short simulation gives the free-fall result that symplectic Euler must give exactly,
every bundled backend module, defsim.io, and the command line the package carries: `defsim run`
of a shipped scene (defsim.scenes) through the console entry point and `python -m defsim`, the
same bit for bit; with ``--sweep`` (the sweep extras installed) a 2-worker `defsim-sweep` whose
rows equal `defsim run` of the same variants.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

import defsim

pkg = os.path.dirname(os.path.abspath(defsim.__file__))
assert "site-packages" in pkg, f"defsim imported from {pkg}, not from the virtual environment"
assert os.path.dirname(os.path.abspath(defsim.library_path)) == pkg, defsim.library_path
assert sys.modules["defsim._defsim_ffi"].__file__.startswith(pkg)   # the generated declarations
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

# The command line: the console script `defsim` (in the venv's bin, beside this python) and
# `python -m defsim` run the C tool the package carries, on a scene the package carries.
import defsim.scenes  # noqa: E402

bindir = os.path.dirname(sys.executable)
scene = defsim.scenes.path("cantilever")
assert scene.startswith(pkg), scene
assert {"cantilever", "cloth", "rope"} <= set(defsim.scenes.names())
env = {k: v for k, v in os.environ.items() if not k.startswith("DEFSIM_")}
env["PATH"] = bindir + os.pathsep + "/usr/bin:/bin"   # no other defsim to find


def defsim_run(cmd, out):
    r = subprocess.run(cmd + ["run", scene, "--set", "world.duration=0.05", "--out", out,
                              "--summary-json", os.path.join(out, "summary.json")],
                       env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, (cmd, r.stdout, r.stderr)
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


with tempfile.TemporaryDirectory() as tmp:
    a = defsim_run([os.path.join(bindir, "defsim")], os.path.join(tmp, "a"))
    b = defsim_run([sys.executable, "-m", "defsim"], os.path.join(tmp, "b"))
    assert a["status"] == "ok" and a["steps"] == 80 and a["failed_steps"] == 0, a   # 2 frames at 30 fps
    assert a["probes"] == b["probes"] and a["probes"][0]["position"][1] < 1.0, (a, b)
    assert os.path.isfile(os.path.join(tmp, "a", "final.vtu"))
    version = subprocess.run([os.path.join(bindir, "defsim"), "--version"], env=env,
                             capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and defsim.__version__ in version.stdout, version
    # The tools: `defsim stress` lists its runs and runs one on a bundled module's backend.
    listing = subprocess.run([os.path.join(bindir, "defsim"), "stress", "--reduced",
                              "--list-variants"], env=env, capture_output=True, text=True,
                             timeout=120)
    assert listing.returncode == 0, listing.stderr
    runs = [json.loads(ln) for ln in listing.stdout.splitlines() if ln.strip()]
    k = next(r["index"] for r in runs if r["backend"] == "newton_cholmod")
    row = subprocess.run([os.path.join(bindir, "defsim"), "stress", "--reduced", "--variant",
                          str(k)], env=env, capture_output=True, text=True, timeout=300)
    assert row.returncode == 0 and "newton_cholmod" in row.stdout, (row.stdout, row.stderr)
    cli_note = (f"defsim run (tip y {a['probes'][0]['position'][1]:.6f}), defsim stress "
                f"({len(runs)} runs listed, run {k} on newton_cholmod)")
    if "--sweep" in sys.argv:
        # Two variants on a 2-worker LocalCluster, through the console script, with nothing but
        # the venv on PATH: the rows are `defsim run`'s of the same variants, bit for bit.
        out = os.path.join(tmp, "sweep")
        r = subprocess.run([os.path.join(bindir, "defsim-sweep"), scene, "--out", out,
                            "--workers", "2", "--no-progress",
                            "--grid", "bodies.0.material.youngs_modulus=1e5,1e6",
                            "--grid", "world.duration=0.05"],
                           env=env, capture_output=True, text=True, timeout=600, cwd=tmp)
        assert r.returncode == 0, (r.stdout, r.stderr)
        from defsim.sweep import read_results
        df = read_results(out)
        df["E"] = [json.loads(o)["bodies.0.material.youngs_modulus"] for o in df["overrides"]]
        df = df.sort_values("E")
        assert list(df["status"]) == ["ok", "ok"], df
        assert list(df["E"]) == [1e5, 1e6]
        tips = []
        for E, y in zip(df["E"], df["probe0_y"]):
            s1 = subprocess.run([os.path.join(bindir, "defsim"), "run", scene, "--set",
                                 "world.duration=0.05", "--set",
                                 f"bodies.0.material.youngs_modulus={E!r}", "--out",
                                 os.path.join(tmp, "one"), "--summary-json",
                                 os.path.join(tmp, "one.json")],
                                env=env, capture_output=True, text=True, timeout=300)
            assert s1.returncode == 0, s1.stderr
            with open(os.path.join(tmp, "one.json")) as f:
                ref = json.load(f)["probes"][0]["position"][1]
            assert y == ref, (E, y, ref)
            tips.append(y)
        assert tips[0] != tips[1] and max(tips) < 1.0, tips   # fallen, and each E its own
        cli_note += f", defsim-sweep on 2 workers (tip y {tips[0]:.9f}, {tips[1]:.9f})"
    shutil.rmtree(os.path.join(tmp, "a"))

print(f"defsim {defsim.__version__} from {pkg}; bundled modules: {names or 'none'}; {io_note}; "
      f"{cli_note}; python {sys.version.split()[0]}")
