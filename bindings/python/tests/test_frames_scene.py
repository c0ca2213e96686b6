# SPDX-License-Identifier: MIT
"""Frames with the whole scene (issue 28): a block at rest on a ground plane beside a moving
sphere and a turned box collider, and a pinned rope. `defsim run` and Python's writer (the
same C code, defsim_vtk_write_world) write the bodies' .vtu with every field, the colliders'
geometry at their poses in a second .vtu and a .vtm of both; read back with meshio (an
independent reader) and checked against the analytic surfaces, the block's weight and each
other."""
from __future__ import annotations

import json
import os
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import defsim
import defsim.io as dio

meshio = pytest.importorskip("meshio", reason="the frame tests read with meshio "
                                              "(pip install 'defsim-fem[io]')")

SPHERE_PATH = [(0.0, (0.6, 0.25, 0.0)), (1.0, (0.6, 0.45, 0.1))]
BOX = {"position": (-0.6, 0.15, 0.3), "half": (0.1, 0.15, 0.05), "euler_deg": (10, 30, 0)}

SCENE = {
    "world": {"backend": "newton_cholmod", "h": 0.01, "frame_steps": 10, "duration": 1.5},
    "bodies": [
        {"name": "block",
         "mesh": {"type": "box", "lo": [-0.1, 0.002, -0.1], "hi": [0.1, 0.202, 0.1],
                  "cells": [2, 2, 2]},
         "material": {"model": "stable_neohookean", "youngs_modulus": 1e5, "poisson_ratio": 0.3,
                      "density": 500, "mass_damping": 8}},
        {"name": "rope", "mesh": {"type": "rope", "a": [-0.5, 1.0, 0], "b": [-0.1, 1.0, 0],
                                  "segments": 4},
         "material": {"model": "spring", "stiffness": 500, "total_mass": 0.05,
                      "mass_damping": 1}, "pin": [0]},
    ],
    "colliders": [
        {"shape": "plane", "position": [0, 0, 0], "normal": [0, 1, 0]},
        {"shape": "sphere", "position": list(SPHERE_PATH[0][1]), "radius": 0.2,
         "path": [{"t": t, "position": list(p)} for t, p in SPHERE_PATH]},
        {"shape": "box", "position": list(BOX["position"]), "half_extents": list(BOX["half"]),
         "euler_deg": list(BOX["euler_deg"])},
    ],
}

FIELDS = ["velocity", "displacement", "pin_force", "contact_force", "pinned"]
CELL_FIELDS = ["body", "cauchy_stress", "von_mises", "energy_density"]


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("frames")
    path = d / "rest.json"
    path.write_text(json.dumps(SCENE))
    return path


def _defsim_run(scene_file, out):
    exe = os.environ.get("DEFSIM_EXE")
    if not exe:
        pytest.skip("DEFSIM_EXE (the build's defsim) is not set")
    subprocess.run([exe, "run", str(scene_file), "--progress", "none", "--out", str(out)],
                   check=True, capture_output=True)


def _sphere_centre(t):
    (t0, a), (t1, b) = SPHERE_PATH
    s = min(max((t - t0) / (t1 - t0), 0.0), 1.0)
    return np.array(a) + s * (np.array(b) - np.array(a))


def _euler_matrix(deg):
    # The scene's euler_deg: rotations about x, then y, then z (R = Rz Ry Rx).
    ax, ay, az = np.radians(deg)
    rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rz @ ry @ rx


def _blocks(vtm_path):
    root = ET.parse(vtm_path).getroot()
    assert root.get("type") == "vtkMultiBlockDataSet"
    return {d.get("name"): os.path.join(os.path.dirname(vtm_path), d.get("file"))
            for d in root.iter("DataSet")}


def _check_colliders(path, t, bodies_x):
    """The colliders' .vtu at time t: each collider's vertices on its analytic surface at its
    pose (the sphere where its path is at t)."""
    m = meshio.read(path)
    tri = m.cells_dict["triangle"]
    col = np.concatenate([c for c in m.cell_data["collider"]]).reshape(-1)
    shape = np.concatenate([c for c in m.cell_data["shape"]]).reshape(-1)
    assert sorted(set(col.tolist())) == [0, 1, 2]
    pts = {k: m.points[np.unique(tri[col == k])] for k in range(3)}
    assert set(shape[col == 0]) == {0} and set(shape[col == 1]) == {1} and set(shape[col == 2]) == {2}
    # Plane: a square of 4 corners on y = 0, about the scene and covering the block.
    plane = pts[0]
    assert plane.shape == (4, 3) and np.abs(plane[:, 1]).max() == 0.0
    lo, hi = plane.min(0), plane.max(0)
    assert (lo[[0, 2]] < bodies_x.min(0)[[0, 2]]).all() and (hi[[0, 2]] > bodies_x.max(0)[[0, 2]]).all()
    # Sphere: |p - c(t)| = r.
    r = np.linalg.norm(pts[1] - _sphere_centre(t), axis=1)
    np.testing.assert_allclose(r, 0.2, rtol=0, atol=1e-12)
    assert pts[1].shape[0] > 100
    # Box: in its own frame every corner is at (+-hx, +-hy, +-hz).
    local = (pts[2] - np.array(BOX["position"])) @ _euler_matrix(BOX["euler_deg"])
    assert pts[2].shape == (8, 3)
    np.testing.assert_allclose(np.abs(local), np.tile(BOX["half"], (8, 1)), rtol=0, atol=1e-12)
    # Outward triangles: every normal of a convex shape points away from its centre.
    for k, c in ((1, _sphere_centre(t)), (2, np.array(BOX["position"]))):
        t3 = m.points[tri[col == k]]
        n = np.cross(t3[:, 1] - t3[:, 0], t3[:, 2] - t3[:, 0])
        assert (np.einsum("ij,ij->i", n, t3.mean(1) - c) > 0).all()


def test_defsim_run_frames_carry_the_scene(scene_file, tmp_path):
    out = tmp_path / "run"
    _defsim_run(scene_file, out)
    frames = 15
    for f in (0, 7, frames):
        stem = out / f"frame_{f:05d}"
        blocks = _blocks(f"{stem}.vtm")
        assert blocks == {"bodies": f"{stem}.vtu", "colliders": f"{stem}_colliders.vtu"}
        bodies = meshio.read(blocks["bodies"])
        t = float(bodies.field_data["TimeValue"][0])
        assert t == pytest.approx(0.1 * f, abs=1e-12)
        _check_colliders(blocks["colliders"], t, bodies.points)
    # The .pvd of the whole scene lists the .vtm frames; the bodies' .pvd stays as it was.
    listed = [d.get("file") for d in ET.parse(out / "rest_scene.pvd").getroot().iter("DataSet")]
    assert listed == [f"frame_{f:05d}.vtm" for f in range(frames + 1)]
    listed = [d.get("file") for d in ET.parse(out / "rest.pvd").getroot().iter("DataSet")]
    assert listed == [f"frame_{f:05d}.vtu" for f in range(frames + 1)]
    assert (out / "final.vtm").exists() and (out / "final_colliders.vtu").exists()
    # At rest on the plane the contact forces on the block carry its weight (4 kg); the rope
    # touches nothing, and its pin holds the rope's weight.
    last = meshio.read(out / f"frame_{frames:05d}.vtu")
    for name in FIELDS:
        assert name in last.point_data, name
    for name in CELL_FIELDS:
        assert name in last.cell_data, name
    nblock = 27
    cf = last.point_data["contact_force"]
    weight = 500 * 0.2 ** 3 * 9.81
    np.testing.assert_allclose(cf[:nblock].sum(0), [0, weight, 0], rtol=0, atol=1e-4 * weight)
    assert np.abs(cf[nblock:]).max() == 0.0
    assert (cf[:nblock, 1] >= 0).all() and (cf[:nblock, 1] > 0).sum() == 9   # the bottom face
    assert np.abs(last.point_data["velocity"][:nblock]).max() < 1e-3
    assert last.point_data["pinned"].reshape(-1).tolist() == [0] * nblock + [1, 0, 0, 0, 0]


def test_python_writer_writes_what_defsim_run_writes(scene_file, tmp_path):
    _defsim_run(scene_file, tmp_path / "run")
    scene = dio.load_scene(scene_file)
    scene.run(tmp_path / "py")
    frames = scene.frames
    for f in (0, frames):
        ref = meshio.read(tmp_path / "run" / f"frame_{f:05d}.vtu")
        got = meshio.read(tmp_path / "py" / f"rest_{f:05d}.vtu")
        assert sorted(got.point_data) == sorted(ref.point_data) == sorted(FIELDS)
        assert sorted(got.cell_data) == sorted(ref.cell_data) == sorted(CELL_FIELDS)
        np.testing.assert_array_equal(got.points, ref.points)
        for name in FIELDS:
            np.testing.assert_array_equal(got.point_data[name], ref.point_data[name], name)
        for name in CELL_FIELDS:
            for a, b in zip(got.cell_data[name], ref.cell_data[name]):
                np.testing.assert_array_equal(a, b, name)
        # The colliders' geometry the same, bit for bit (planes sized from the first frame).
        a = meshio.read(tmp_path / "py" / f"rest_{f:05d}_colliders.vtu")
        b = meshio.read(tmp_path / "run" / f"frame_{f:05d}_colliders.vtu")
        np.testing.assert_array_equal(a.points, b.points)
        assert _blocks(tmp_path / "py" / f"rest_{f:05d}.vtm")["colliders"].endswith(
            f"rest_{f:05d}_colliders.vtu")
    listed = [d.get("file") for d in ET.parse(tmp_path / "py" / "rest_scene.pvd").getroot()
              .iter("DataSet")]
    assert listed == [f"rest_{f:05d}.vtm" for f in range(frames + 1)]


def test_python_world_frames(tmp_path):
    """A world built in Python: write_vtu carries cauchy_stress, pin_force, pinned and
    contact_force, and the .vtm with the colliders; colliders=False writes the bodies alone."""
    w = defsim.World("symplectic_euler")
    m = defsim.mesh_box((0, 0.5, 0), (0.4, 0.6, 0.1), cells=(4, 1, 1))
    beam = w.add_body(m, material=defsim.Material("corotated", youngs_modulus=1e5,
                                                  poisson_ratio=0.3, density=1000))
    w.pin(beam, m.positions[:, 0] == 0.0)
    w.add_collider("sphere", position=(0.3, 0.3, 0.05), radius=0.15)
    # Two attachments on the free end's vertex 4 and one on vertex 9 (body-local).
    tip = int(np.flatnonzero(m.positions[:, 0] == 0.4)[0])
    other = int(np.flatnonzero(m.positions[:, 0] == 0.4)[1])
    a1 = w.add_attachment(beam, tip, (0.5, 0.7, 0.0), stiffness=50.0)
    a2 = w.add_attachment(beam, tip, (0.4, 0.3, 0.1), stiffness=20.0)
    a3 = w.add_attachment(beam, other, (0.6, 0.6, 0.1), stiffness=30.0)
    w.step(1e-4, steps=20)
    assert dio.write_vtu(w, tmp_path / "a.vtu") is True
    got = meshio.read(tmp_path / "a.vtu")
    for name in ("velocity", "displacement", "pin_force", "pinned", "contact_force",
                 "attachment_force"):
        assert name in got.point_data, name
    want = np.zeros((w.vertex_count, 3))
    want[beam.vertex_offset + tip] += a1.force + a2.force
    want[beam.vertex_offset + other] += a3.force
    np.testing.assert_array_equal(got.point_data["attachment_force"], want)
    assert np.abs(want).max() > 0
    np.testing.assert_array_equal(got.point_data["pin_force"], w.pin_forces())
    np.testing.assert_array_equal(got.point_data["contact_force"], w.contact_forces())
    assert got.point_data["pinned"].reshape(-1).tolist() == (m.positions[:, 0] == 0.0).astype(int).tolist()
    cauchy = np.concatenate(got.cell_data["cauchy_stress"]).reshape(-1, 3, 3)
    np.testing.assert_array_equal(cauchy, beam.element_stress().cauchy.reshape(-1, 3, 3))
    sphere = meshio.read(tmp_path / "a_colliders.vtu").points
    np.testing.assert_allclose(np.linalg.norm(sphere - (0.3, 0.3, 0.05), axis=1), 0.15,
                               rtol=0, atol=1e-12)
    # A capsule turned about z (its axis along x) and a mesh pyramid turned about y, moved:
    # the capsule's vertices within r of its axis segment, the mesh's at R p + c.
    q = (np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4))
    w.add_collider("capsule", position=(2.0, 0.3, 0.0), rotation=q, radius=0.1, half_height=0.25)
    pyramid = np.array([[0, 0, 0], [0.2, 0, 0], [0, 0, 0.2], [0, 0.2, 0]], float)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    qy = (np.cos(0.3), 0.0, np.sin(0.3), 0.0)
    w.add_collider("mesh", position=(-1.0, 0.2, 0.5), rotation=qy, vertices=pyramid,
                   triangles=faces)
    assert dio.write_vtu(w, tmp_path / "d.vtu") is True
    col = meshio.read(tmp_path / "d_colliders.vtu")
    tag = np.concatenate(col.cell_data["collider"]).reshape(-1)
    tri = col.cells_dict["triangle"]
    cap = col.points[np.unique(tri[tag == 1])]
    s = np.clip(cap[:, 0] - 2.0, -0.25, 0.25)   # along the axis, clamped to the segment
    dist = np.linalg.norm(cap - np.stack([2.0 + s, np.full_like(s, 0.3), 0 * s], 1), axis=1)
    np.testing.assert_allclose(dist, 0.1, rtol=0, atol=1e-12)
    assert np.ptp(cap[:, 0]) == pytest.approx(0.7, abs=1e-12)   # 2 (h + r) along x
    ry = np.array([[np.cos(0.6), 0, np.sin(0.6)], [0, 1, 0], [-np.sin(0.6), 0, np.cos(0.6)]])
    mesh_pts = col.points[np.unique(tri[tag == 2])]
    np.testing.assert_allclose(mesh_pts, pyramid @ ry.T + (-1.0, 0.2, 0.5), rtol=0, atol=1e-12)
    assert tri[tag == 2].shape == (4, 3)
    assert dio.write_vtu(w, tmp_path / "b.vtu", colliders=False) is False
    assert not (tmp_path / "b.vtm").exists() and not (tmp_path / "b_colliders.vtu").exists()
    with pytest.raises(defsim.InvalidArgumentError):
        dio.write_vtu(w, tmp_path / "c.vtk")


def test_contact_force_holds_body_contact(tmp_path):
    """contact_force carries body contact too: in tests/scenes/cube_stack.json at rest each
    cube's contact forces sum to its weight (8 kg x 9.81), the middle and top cubes' from body
    contact alone (only the bottom one touches the ground collider)."""
    scenes = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "tests",
                          "scenes")
    exe = os.environ.get("DEFSIM_EXE")
    if not exe:
        pytest.skip("DEFSIM_EXE (the build's defsim) is not set")
    subprocess.run([exe, "run", os.path.join(scenes, "cube_stack.json"), "--vtk", "final",
                    "--progress", "none", "--out", str(tmp_path)], check=True,
                   capture_output=True)
    m = meshio.read(tmp_path / "final.vtu")
    body = np.concatenate(m.cell_data["body"]).reshape(-1)
    tets = m.cells_dict["tetra"]
    cf = m.point_data["contact_force"]
    weight = 0.2 ** 3 * 1000 * 9.81
    for b in range(3):
        verts = np.unique(tets[body == b])
        assert verts.size == 64
        np.testing.assert_allclose(cf[verts].sum(0), [0, weight, 0], rtol=0, atol=1e-3 * weight)
    # The middle cube's bottom pushed up by the bottom cube, its top pushed down by the top one.
    mid = np.unique(tets[body == 1])
    y = m.points[mid, 1]
    half = 0.5 * (y.min() + y.max())
    np.testing.assert_allclose(cf[mid][y < half, 1].sum(), 2 * weight, rtol=1e-3)
    np.testing.assert_allclose(cf[mid][y > half, 1].sum(), -weight, rtol=1e-3)
