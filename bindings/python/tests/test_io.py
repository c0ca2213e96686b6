# SPDX-License-Identifier: MIT
"""defsim.io: VTK frames written by the C writer and read back by meshio, meshes of several
formats read through meshio, scene files through the parser of `defsim run`, progress."""
from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pytest

import defsim
import defsim.io as dio

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.normpath(os.path.join(HERE, "..", "..", "..", "tests", "scenes"))


def _beam_world():
    w = defsim.World("symplectic_euler")
    m = defsim.mesh_box((0, 0, 0), (1.0, 0.2, 0.2), cells=(5, 1, 1))
    beam = w.add_body(m, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                  poisson_ratio=0.3, density=1000))
    w.pin(beam, m.positions[:, 0] == 0.0)
    rope = w.add_body(defsim.mesh_rope((0, 1, 0), (1, 1, 0), 4),
                      material=defsim.Material("spring", stiffness=100, vertex_mass=0.01))
    return w, beam, rope


def test_frame_cells_follow_defsim_run():
    w, beam, rope = _beam_world()
    types, offsets, conn, body = dio.frame_cells(w)
    # 30 tets of the beam, then the rope's 4 links (its 3 bending springs are not drawn).
    assert list(np.bincount(types)[[3, 10]]) == [4, 30]
    assert offsets[-1] == conn.size == 30 * 4 + 4 * 2
    assert (body[:30] == 0).all() and (body[30:] == 1).all()
    off = rope.vertex_offset
    assert off == beam.vertex_count == 24
    assert conn[120:].reshape(-1, 2).tolist() == [[off + i, off + i + 1] for i in range(4)]


def test_write_vtu_read_back_with_meshio(tmp_path):
    meshio = pytest.importorskip("meshio", reason="defsim.io tests need meshio (pip install "
                                                  "'defsim-fem[io]')")
    w, beam, rope = _beam_world()
    w.step(1e-3, steps=30)
    path = tmp_path / "frame.vtu"
    dio.write_vtu(w, path)
    m = meshio.read(path)
    x = w.positions
    np.testing.assert_array_equal(m.points, x)                     # float64, bit for bit
    np.testing.assert_array_equal(m.point_data["velocity"], w.velocities)
    rest = np.concatenate([w.topology(b).rest for b in w.bodies])
    np.testing.assert_array_equal(m.point_data["displacement"], x - rest)
    tets = m.cells_dict["tetra"]
    np.testing.assert_array_equal(tets, w.topology(beam).tets)
    vm = np.concatenate(m.cell_data["von_mises"]).reshape(-1)
    stress = beam.element_stress()
    np.testing.assert_array_equal(vm[:30], stress.von_mises)
    assert (vm[30:] == 0).all() and stress.von_mises.max() > 0
    assert float(m.field_data["TimeValue"][0]) == pytest.approx(w.time, abs=0)
    # The fields `defsim run` writes (issue 28: Python's frames lacked these three).
    cauchy = np.concatenate(m.cell_data["cauchy_stress"]).reshape(-1, 9)
    np.testing.assert_array_equal(cauchy[:30], stress.cauchy.reshape(30, 9))
    np.testing.assert_array_equal(m.point_data["pin_force"], w.pin_forces())
    assert m.point_data["pinned"].reshape(-1).tolist() == (
        [1 if p[0] == 0.0 else 0 for p in w.topology(beam).rest] + [0] * rope.vertex_count)


def test_series_pvd_lists_frames_with_times(tmp_path):
    meshio = pytest.importorskip("meshio")
    w, _, _ = _beam_world()
    s = dio.Series(tmp_path / "out", name="beam")
    for _ in range(3):
        s.write(w)
        w.step(1e-3, steps=5)
    assert len(s) == 3 and s.files == [f"beam_{i:05d}.vtu" for i in range(3)]
    text = open(s.pvd_path).read()
    for f, t in zip(s.files, s.times):
        assert f'file="{f}"' in text
    assert s.times == pytest.approx([0.0, 0.005, 0.010], abs=1e-15)
    first = meshio.read(os.path.join(s.folder, s.files[0]))
    assert np.abs(first.point_data["displacement"]).max() == 0.0   # measured from frame 0
    with pytest.raises(defsim.InvalidArgumentError):
        dio.Series(tmp_path, name="a/b")


def test_write_vtu_errors(tmp_path):
    w, _, _ = _beam_world()
    with pytest.raises(defsim.FileError):
        dio.write_vtu(w, tmp_path / "missing" / "deeper" / "f.vtu")
    with pytest.raises(defsim.InvalidArgumentError):
        dio.write_vtu(w, tmp_path / "f.vtu", reference=np.zeros((3, 3)))


# -- meshio formats --------------------------------------------------------------------------

def _two_tets():
    # Two tets sharing a face, the second negatively oriented, plus a point no cell uses (3)
    # and a surface triangle block that a tet mesh ignores.
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [9, 9, 9], [0, 0, 1], [0, 0, -1]], float)
    tets = np.array([[0, 1, 2, 4], [0, 2, 1, 5]])
    return pts, tets


@pytest.mark.parametrize("ext,fmt", [(".vtu", None), (".vtk", None), (".msh", "gmsh22"),
                                     (".mesh", None), (".inp", None), (".off", None)])
def test_read_mesh_formats(tmp_path, ext, fmt):
    meshio = pytest.importorskip("meshio")
    pts, tets = _two_tets()
    path = str(tmp_path / f"m{ext}")
    if ext == ".off":
        # A surface format: triangles make a cloth with its unique edges as springs.
        tris = np.array([[0, 1, 2], [1, 4, 2]])
        meshio.write(path, meshio.Mesh(pts, [("triangle", tris)]))
        m = dio.read_mesh(path)
        assert m.tet_count == 0 and m.triangle_count == 2 and m.spring_count == 5
        assert m.vertex_count == 4
        return
    kw = {"file_format": fmt} if fmt else {}
    if ext == ".msh":
        kw["binary"] = False
    meshio.write(path, meshio.Mesh(pts, [("triangle", np.array([[0, 1, 2]])), ("tetra", tets)]),
                 **kw)
    m = dio.read_mesh(path)
    assert m.vertex_count == 5 and m.tet_count == 2
    np.testing.assert_allclose(m.positions, pts[[0, 1, 2, 4, 5]], atol=1e-12)
    # Both tets positively oriented; boundary: 6 faces (the shared one is inside).
    d = m.positions[m.tets[:, :3]] - m.positions[m.tets[:, 3:4]]
    assert (np.linalg.det(d) > 0).all()
    assert m.triangle_count == 6
    # The mesh makes a body; its volume is right: 2 * 1/6, so the mass is rho/3.
    with defsim.World() as w:
        w.add_body(m, material=defsim.Material("neohookean", youngs_modulus=1e4,
                                               poisson_ratio=0.3, density=600))
        assert w.masses.sum() == pytest.approx(600 / 3, rel=1e-12)


def test_read_mesh_lines_and_errors(tmp_path):
    meshio = pytest.importorskip("meshio")
    pts = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)
    path = str(tmp_path / "rope.vtu")
    meshio.write(path, meshio.Mesh(pts, [("line", np.array([[0, 1], [1, 2], [2, 1]]))]))
    m = dio.read_mesh(path)
    assert m.spring_count == 2 and m.tet_count == 0 and m.triangle_count == 0
    hexa = str(tmp_path / "hex.vtu")
    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1],
                     [1, 1, 1], [0, 1, 1]], float)
    meshio.write(hexa, meshio.Mesh(cube, [("hexahedron", np.arange(8)[None])]))
    with pytest.raises(defsim.InvalidMeshError, match="hexahedron"):
        dio.read_mesh(hexa)
    bad = tmp_path / "bad.vtu"
    bad.write_text("not xml")
    with pytest.raises(defsim.FileError):
        dio.read_mesh(bad)


# -- scene files -----------------------------------------------------------------------------

def test_scene_matches_defsim_run(tmp_path):
    """The same scene through the library's parser: the same energies, bit for bit, as `defsim
    run` (whose driven clamp only moves when the scene steps it)."""
    exe = os.environ.get("DEFSIM_EXE")
    if not exe:
        pytest.skip("DEFSIM_EXE (the build's defsim) is not set")
    scene_path = os.path.join(SCENES, "driven_circle.json")
    summary = tmp_path / "s.json"
    subprocess.run([exe, "run", scene_path, "--set", "world.duration=0.05", "--no-vtk",
                    "--progress", "none", "--out", str(tmp_path / "o"), "--summary-json",
                    str(summary)], check=True, capture_output=True)
    ref = json.loads(summary.read_text())
    scene = dio.load_scene(scene_path, {"world.duration": 0.05})
    assert scene.name == "driven_circle" and scene.backend == "symplectic_euler"
    assert scene.frames * scene.frame_steps == ref["steps"] == 80
    done = []
    world = scene.run(tmp_path / "py", progress=lambda i, n: done.append((i, n)))
    assert done[-1] == (80, 80) and len(done) == 80
    e = world.energy()
    assert (e.kinetic, e.elastic, e.total) == (ref["energy_end"]["kinetic"],
                                               ref["energy_end"]["elastic"],
                                               ref["energy_end"]["total"])
    probe = ref["probes"][0]
    assert list(world.positions[probe["vertex"]]) == probe["position"]
    assert len(os.listdir(tmp_path / "py")) == 1 + scene.frames + 1   # .pvd + initial + frames


def test_scene_errors_and_overrides(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"world": {"h": 1e-3, "duration": 0.1},\n "bodies": [{"mesh": {"type": '
                   '"box", "lo": [0,0,0], "hi": [1,1,1], "cells": [1,1,1]},\n "colour": [1,0,0]}]}')
    with pytest.raises(defsim.InvalidArgumentError, match=r"bad\.json:3:"):
        dio.load_scene(bad)
    # Issue 28 (5): a missing scene file is a FileError, as every other missing file is (it was
    # InvalidArgumentError); so is a missing mesh file the scene names.
    with pytest.raises(defsim.FileError, match="missing.json") as info:
        dio.load_scene(tmp_path / "missing.json")
    assert info.value.status == defsim.Status.IO
    with pytest.raises(defsim.FileError):
        dio.load_scene(tmp_path)   # a folder, not a regular file
    nomesh = tmp_path / "nomesh.json"
    nomesh.write_text('{"world": {"h": 1e-3, "duration": 0.1}, "bodies": [{"mesh": "gone.msh"}]}')
    with pytest.raises(defsim.FileError, match="gone.msh"):
        dio.load_scene(nomesh)
    s = dio.load_scene(os.path.join(SCENES, "cloth.json"),
                       {"world.backend": "explicit_euler", "world.h": 1e-4})
    assert s.backend == "explicit_euler" and s.step_size == 1e-4
    assert s.body_names == ["cloth"]
    w = s.world
    assert w.vertex_count == 21 * 21 and w.topology(w.bodies[0]).triangles.shape == (800, 3)
    s.step(steps=3)
    assert w.time == pytest.approx(3e-4, rel=1e-12)
    with pytest.raises(defsim.InvalidArgumentError):
        s.step(h=-1.0)


def test_scene_cloth_stiffness_by_kind_matches_python():
    """The scene's shear_stiffness / bending_stiffness and the Python per-kind arguments make
    the same cloth: equal energies at the same stretched state."""
    s = dio.load_scene(os.path.join(SCENES, "cloth.json"))
    ws = s.world
    mesh = defsim.mesh_cloth((0, 1, 0), (1, 0, 0), (0, 0, 1), 20, 20)
    with defsim.World(gravity=(0, 0, 0)) as w:
        w.add_body(mesh, material=defsim.Material("spring", stiffness=400,
                                                  vertex_mass=0.2 / mesh.vertex_count),
                   shear_stiffness=100, bend_stiffness=10)
        x = mesh.positions * 1.01
        w.positions = x
        ws.positions = x
        assert w.energy().elastic == pytest.approx(ws.energy().elastic, rel=1e-12)


# -- progress --------------------------------------------------------------------------------

def test_step_progress_callable_and_tqdm(world, box):
    world.add_body(box, material=defsim.Material("stvk", youngs_modulus=1e5,
                                                 poisson_ratio=0.3, density=1000))
    seen = []
    world.step(1e-4, steps=7, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(i, 7) for i in range(1, 8)]

    class Bar:
        n = 0

        def update(self, k):
            self.n += k

    bar = Bar()
    world.step(1e-4, steps=5, progress=bar)
    assert bar.n == 5

    def stop(done, total):
        if done == 2:
            raise KeyboardInterrupt

    t = world.time
    with pytest.raises(KeyboardInterrupt):
        world.step(1e-4, steps=10, progress=stop)
    assert world.time == pytest.approx(t + 2e-4, rel=1e-12)   # the steps before it stay done
    with pytest.raises(defsim.InvalidArgumentError):
        world.step(1e-4, steps=1, progress=3)
    tqdm = pytest.importorskip("tqdm")
    world.step(1e-4, steps=4, progress=True)
    assert tqdm is not None


def test_progress_without_tqdm_names_the_extra(world, box, monkeypatch):
    """Issue 28 (5): progress=True without tqdm raised a bare ModuleNotFoundError; it names the
    [progress] extra now, and no step is taken."""
    import sys
    world.add_body(box)
    for name in ("tqdm", "tqdm.auto"):
        monkeypatch.setitem(sys.modules, name, None)   # import tqdm.auto fails as if absent
    with pytest.raises(ModuleNotFoundError, match=r"defsim-fem\[progress\]") as info:
        world.step(1e-4, steps=3, progress=True)
    assert info.value.name == "tqdm"
    assert world.time == 0.0
