# SPDX-License-Identifier: MIT
"""Python builds scenes (issue 28): World.to_scene (defsim_scene_export) writes a world as scene
JSON that loads back (load_scene of a dict, a JSON string or a file) into a world that steps to
the same bits; what a scene cannot hold is refused, not written approximately."""
from __future__ import annotations

import glob
import json
import os

import numpy as np
import pytest

import defsim
import defsim.io as dio

from conftest import world_or_skip

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.normpath(os.path.join(HERE, "..", "..", "..", "tests", "scenes"))


def _bits(a: np.ndarray) -> bytes:
    return np.ascontiguousarray(a, dtype=np.float64).tobytes()


def _same_run(a, step_a, b, step_b, steps: int) -> float:
    """Steps both worlds and asserts equal bits of x and v after every step. Returns the
    largest contact force (N) of a vertex over the steps."""
    most = 0.0
    for i in range(steps):
        step_a()
        step_b()
        assert _bits(a.positions) == _bits(b.positions), f"positions differ after step {i + 1}"
        assert _bits(a.velocities) == _bits(b.velocities), f"velocities differ after step {i + 1}"
        most = max(most, float(np.abs(a.contact_forces()).max(initial=0.0)))
    assert a.time == b.time
    return most


def _rich_world(backend: str, contact: bool) -> defsim.World:
    """Every kind of thing a scene can hold, made in Python."""
    opts = {"core.body_contact": True} if contact else {}
    if backend == "newton_cholmod":
        opts["newton_cholmod.tolerance"] = 1e-7
    w = world_or_skip(backend, gravity=(0.1, -9.81, 0.05), num_threads=1, options=opts)
    beam_mesh = defsim.mesh_box((0, 0.5, 0), (0.6, 0.7, 0.2), cells=(3, 1, 1))
    beam = w.add_body(beam_mesh, material=defsim.Material(
        "corotated", youngs_modulus=2e5, poisson_ratio=0.33, density=900, mass_damping=0.3,
        stiffness_damping=1e-3), friction=0.3, collision_group=2, collision_mask=3)
    beam.pin(beam_mesh.positions[:, 0] == 0.0)
    rope = w.add_body(defsim.mesh_rope((0.7, 0.9, 0.1), (1.2, 0.9, 0.1), 6),
                      material=defsim.Material("spring", stiffness=300, vertex_mass=0.01),
                      bend_stiffness=4.0, self_contact=False)   # contact edges: stretch springs
    cloth_mesh = defsim.mesh_cloth((-0.4, 1.0, -0.2), (0.3, 0, 0), (0, 0, 0.3), 3, 3)
    n = cloth_mesh.vertex_count
    rng = np.random.default_rng(7)
    cloth = w.add_body(cloth_mesh, material=defsim.Material("spring", stiffness=150),
                       shear_stiffness=40.0, bend_stiffness=2.0,
                       vertex_mass=rng.uniform(0.004, 0.006, n),
                       initial_positions=cloth_mesh.positions + [0, 0.01, 0],
                       initial_velocities=rng.normal(0, 0.05, (n, 3)))
    loose = w.add_body(np.array([[0.0, 1.3, 0.3], [0.1, 1.3, 0.3], [0.05, 1.4, 0.3]]),
                       springs=[[0, 1], [1, 2], [2, 0]], spring_stiffness=[50, 60, 70],
                       material=defsim.Material("spring", vertex_mass=0.02))
    f = np.zeros((w.vertex_count, 3))
    f[cloth.vertices] = [0.0, 0.02, 0.0]
    f[cloth.vertex_offset + 5] = [0.01, -0.03, 0.002]
    f[loose.vertices.start] = [0.0, 0.1, 0.0]
    w.set_external_forces(f)
    w.add_attachment(rope, 0, (0.7, 0.9, 0.1), stiffness=500, damping=0.2)
    w.add_attachment(rope, 6, target_body=beam, target_vertices=[5, 6, 7],
                     target_weights=[0.2, 0.3, 0.5], stiffness=200)
    w.add_attachment(loose, 2, stiffness=80)
    w.add_collider("plane", position=(0, -0.2, 0), normal=(0.05, 1, 0), friction=0.4)
    # the cloth's vertex 6 starts 0.5 mm above the sphere: contact within the test's steps
    w.add_collider("sphere", position=(-0.2, 1.01 - 0.1505, -0.1), radius=0.15, friction=0.2)
    q = np.array([0.9, 0.1, 0.3, 0.2])
    w.add_collider("box", position=(-0.25, 0.6, -0.05), rotation=q / np.linalg.norm(q),
                   half_extents=(0.1, 0.05, 0.2))
    w.add_collider("capsule", position=(1.1, 0.5, 0.1), radius=0.05, half_height=0.1,
                   rotation=(np.cos(0.3), 0, 0, np.sin(0.3)))
    w.add_collider("mesh", position=(0.1, 0.95, 0.3),
                   vertices=[[0, 0, 0], [0.2, 0, 0], [0, 0, 0.2], [0, 0.1, 0]],
                   triangles=[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return w


@pytest.mark.parametrize("backend,contact", [("symplectic_euler", False),
                                             ("velocity_verlet", False),
                                             ("newton_cholmod", False),
                                             ("newton_cholmod", True)])
def test_python_world_round_trip_is_bit_identical(backend: str, contact: bool, tmp_path) -> None:
    w = _rich_world(backend, contact)
    scene = w.to_scene(tmp_path / "rich.json", h=5e-4, duration=0.01)
    # A dict, its JSON text and the file give the same scene.
    text = (tmp_path / "rich.json").read_text()
    assert json.loads(text) == scene
    assert scene["world"]["backend"] == backend and scene["world"]["threads"] == 1
    assert len(scene["bodies"]) == 4 and len(scene["attachments"]) == 3
    assert [c["shape"] for c in scene["colliders"]] == ["plane", "sphere", "box", "capsule",
                                                        "mesh"]
    rope = scene["bodies"][1]
    assert rope["mesh"]["spring_kinds"] == [[0]] * 6 + [[2]] * 5   # its contact edges' kinds
    assert rope["material"]["bending_stiffness"] == 4.0
    for source in (scene, text, tmp_path / "rich.json"):
        s = dio.load_scene(source)
        w2 = s.world
        assert _bits(w2.positions) == _bits(w.positions)
        assert _bits(w2.velocities) == _bits(w.velocities)
        assert _bits(w2.masses) == _bits(w.masses)
        assert w2.options() == w.options()
    touch = _same_run(w, lambda: w.step(5e-4), w2, lambda: s.step(5e-4), 25)
    assert touch > 1e-3   # the cloth touches the sphere (N)


def test_export_of_an_export_is_the_same() -> None:
    """Exporting the world a scene made gives that scene again, bit for bit in every number
    (the plane's normal and the box's rotation included, which the library normalises: the
    file marks them "normalized" so that they are kept as they are), plus what a scene adds:
    the bodies' colours and the frame length."""
    w = _rich_world("symplectic_euler", False)
    a = w.to_scene(h=1e-3, duration=0.5)
    b = dio.load_scene(a).world.to_scene(h=1e-3, duration=0.5)
    assert b["world"].pop("frame_steps") == 33
    for body in b["bodies"]:
        assert len(body.pop("color")) == 3
    assert json.dumps(a) == json.dumps(b)
    assert a["colliders"][0]["normalized"] is True


@pytest.mark.parametrize("path", sorted(glob.glob(os.path.join(SCENES, "*.json"))),
                         ids=lambda p: os.path.basename(p))
def test_shipped_scene_round_trip_is_bit_identical(path: str) -> None:
    """Every shipped scene: its world exported (with its drives, keyed targets and collider
    paths), loaded back and stepped beside the original, same bits at every step."""
    try:
        s = dio.load_scene(path)
        w = s.world
    except defsim.BackendUnavailableError:
        built = os.environ.get("DEFSIM_TEST_BACKENDS")
        backend = dio.load_scene(path).backend
        if built is not None and backend in built.split(","):
            raise
        pytest.skip(f"backend {backend} is not in this build")
    exported = w.to_scene()
    assert exported["world"]["h"] == s.step_size and exported["world"]["duration"] == s.duration
    assert [b["name"] for b in exported["bodies"]] == s.body_names
    s2 = dio.load_scene(exported, folder=SCENES)
    w2 = s2.world
    # cube_pile: 5,488 vertices on newton_cholmod; the cloth folds: body contact, 1 s a step
    steps = {"cube_pile.json": 1, "cloth_fold.json": 6,
             "cloth_fold_shell.json": 6}.get(os.path.basename(path), 20)
    _same_run(w, s.step, w2, s2.step, steps)


def test_scene_drives_and_paths_are_exported() -> None:
    s = dio.load_scene(os.path.join(SCENES, "driven_circle.json"))
    scene = s.world.to_scene()
    drives = [b["drive"] for b in scene["bodies"] if "drive" in b]
    assert drives and all("vector" in k["rotate"] for d in drives[0] for k in d["keys"])
    # a scene's keyed paths restart at t = 0: refused once the world has moved on
    s.step()
    with pytest.raises(defsim.UnsupportedError, match="t = "):
        s.world.to_scene()


def test_stepped_world_exports_its_state() -> None:
    w = _rich_world("symplectic_euler", False)
    w.step(1e-3, steps=5)
    scene = w.to_scene()
    x = np.concatenate([np.asarray(b.get("initial_positions", b["mesh"]["positions"]))
                        for b in scene["bodies"]])
    v = np.concatenate([np.asarray(b.get("initial_velocities",
                                         np.zeros((len(b["masses"]), 3))))
                        for b in scene["bodies"]])
    assert _bits(x) == _bits(w.positions) and _bits(v) == _bits(w.velocities)
    w2 = dio.load_scene(scene).world
    assert _bits(w2.positions) == _bits(w.positions) and w2.time == 0.0


def test_what_a_scene_cannot_hold_is_refused(box: defsim.Mesh) -> None:
    def fresh() -> defsim.World:
        w = defsim.World("symplectic_euler")
        w.add_body(box)
        return w

    w = fresh()
    w.set_force_callback(lambda x, v, t: np.zeros_like(x))
    with pytest.raises(defsim.UnsupportedError, match="force callback"):
        w.to_scene()
    w.set_force_callback(None)
    w.to_scene()

    w = fresh()
    w.add_collider("sdf", sdf=lambda p: (p[1], (0.0, 1.0, 0.0)))
    with pytest.raises(defsim.UnsupportedError, match="SDF") as info:
        w.to_scene()
    assert info.value.status == defsim.Status.UNSUPPORTED

    w = fresh()
    b = w.bodies[0]
    b.set_pin_targets([0], [[0.0, 0.01, 0.0]])
    with pytest.raises(defsim.UnsupportedError, match="driven-pin targets"):
        w.to_scene()
    x = w.positions
    w.step(1e-4)   # the target is consumed by the step: then it exports
    assert not np.array_equal(w.positions[0], x[0])
    dio.load_scene(w.to_scene())

    w = fresh()
    c = w.add_collider("sphere", position=(0, -1, 0), radius=0.5)
    c.set_pose((0, -0.9, 0))
    with pytest.raises(defsim.UnsupportedError, match="pose set for the next step"):
        w.to_scene()
    w.step(1e-4)
    assert dio.load_scene(w.to_scene()).world.colliders[0].pose.position == (0.0, -0.9, 0.0)

    with pytest.raises(defsim.InvalidArgumentError):
        fresh().to_scene(h=-1.0)


def test_load_scene_from_dict_and_string(tmp_path) -> None:
    scene = {"world": {"backend": "symplectic_euler", "h": 1e-3, "duration": 0.01},
             "bodies": [{"mesh": {"type": "inline",
                                  "positions": np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0],
                                                         [0, 0, 1]], dtype=float),
                                  "tets": np.array([[0, 1, 2, 3]])},
                         "material": {"model": "stvk", "youngs_modulus": 1e5},
                         "pin": [0]}]}
    s = dio.load_scene(scene)
    assert s.world.vertex_count == 4 and s.body_names == ["body 0"]
    s2 = dio.load_scene(json.dumps(scene, default=lambda a: a.tolist()))
    s3 = dio.load_scene(scene, {"world.h": 5e-4, "bodies.0.material.youngs_modulus": 2e5})
    assert s3.step_size == 5e-4 and s3.name == "<scene>"
    _same_run(s.world, s.step, s2.world, s2.step, 5)
    assert s.world.positions[1, 1] < 0.0   # it falls, pinned at vertex 0
    bad = dict(scene, bodies=[dict(scene["bodies"][0], colour=[1, 0, 0])])
    with pytest.raises(defsim.InvalidArgumentError, match=r"<scene>:1:"):
        dio.load_scene(bad)
    with pytest.raises(defsim.InvalidArgumentError, match="not JSON"):
        dio.load_scene({"world": {"h": float("nan")}})
    # a mesh file named by a dict is found in `folder`
    mesh_scene = {"world": {"h": 1e-3, "duration": 0.01},
                  "bodies": [{"mesh": {"type": "file", "path": "cube.msh"}}]}
    with pytest.raises(defsim.FileError):
        dio.load_scene(mesh_scene, folder=tmp_path)


def test_new_scene_keys_are_checked() -> None:
    """The keys the export writes are checked like every other key: each bad value is refused
    with its position, before anything is built."""
    tet = {"type": "inline", "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
           "tets": [[0, 1, 2, 3]]}
    rope = {"type": "inline", "positions": [[0, 0, 0], [1, 0, 0], [2, 0, 0]],
            "springs": [[0, 1], [1, 2], [0, 2]]}

    def scene(body=None, **top):
        s = {"world": {"h": 1e-3, "duration": 0.01},
             "bodies": [dict({"mesh": tet}, **(body or {})), {"mesh": rope}]}
        s.update(top)
        return s

    bad = [
        scene({"mesh": dict(tet, tets=[[0, 1, 2, 4]])}),                  # index out of range
        scene({"mesh": dict(tet, tets=[[0, 1, 2]])}),                     # not rows of 4
        scene({"mesh": dict(tet, positions=[[0, 0, 0], [1, 0]])}),        # ragged rows
        scene({"mesh": dict(tet, positions=[])}),                         # no vertex
        scene({"mesh": dict(tet, colour=1)}),                             # unknown key
        scene({"masses": [1, 1, 1]}),                                     # 3 masses, 4 vertices
        scene({"initial_positions": tet["positions"],
               "initial_transform": {"translate": [0, 1, 0]}}),
        scene({"initial_velocities": [[0, 0, 0]] * 4, "velocity": [0, 1, 0]}),
        scene({"mesh": dict(tet, springs=[[0, 1]], spring_kinds=[0, 1])}),   # kinds per spring
        scene({"mesh": dict(tet, springs=[[0, 1]], spring_kinds=[3])}),      # not a kind
        scene({"mesh": dict(tet, springs=[[0, 1]], spring_kinds=[0]),
               "spring_stiffness": [5.0]}),                                  # kinds and per spring
        scene(attachments=[{"body": 1, "vertex": 0, "stiffness": 10,
                            "target": {"body": 0, "vertices": [0, 1]}}]),      # no weights
        scene(attachments=[{"body": 1, "vertex": 0, "stiffness": 10,
                            "target": {"body": 0, "vertices": [0, 1, 2, 3, 0],
                                       "weights": [0.2] * 5}}]),              # five vertices
        scene(attachments=[{"body": 1, "vertex": 0, "stiffness": 10,
                            "target": {"point": [0, 0, 0], "weights": [1.0]}}]),
        scene(colliders=[{"shape": "mesh", "mesh": "x.obj", "vertices": [[0, 0, 0]] * 3,
                          "triangles": [[0, 1, 2]]}]),
        scene(colliders=[{"shape": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                          "triangles": [[0, 1, 3]]}]),
        scene(colliders=[{"shape": "sphere", "normalized": 1}]),
        scene({"drive": {"indices": [0], "keys": [{"t": 0, "rotate": {
            "vector": [0, 0, 1], "axis": [0, 0, 1], "degrees": 3}}]}}),
    ]
    for s in bad:
        with pytest.raises(defsim.InvalidArgumentError, match=r"<scene>:1:"):
            dio.load_scene(s)
    # the library still checks what the parser passes on: weights that do not sum to 1
    s = dio.load_scene(scene(attachments=[{"body": 1, "vertex": 0, "stiffness": 10,
                                          "target": {"body": 0, "vertices": [0, 1],
                                                     "weights": [0.5, 0.6]}}]))
    with pytest.raises(defsim.InvalidArgumentError, match="weights"):
        s.world
    # A unit quaternion whose last bits the library's division by its length changes: kept
    # bit for bit when given as "normalized" (C: defsim_collider_def.normalized), changed
    # without; one that is not unit is refused by the library.
    q = [0.21424427007839494, 0.5093606231982167, 0.20485384406841473, -0.8078898754434873]
    assert list(defsim.World().add_collider("box", rotation=q).pose.rotation) != q
    w = dio.load_scene(scene(colliders=[{"shape": "box", "rotation": q,
                                         "normalized": True}])).world
    assert list(w.colliders[0].pose.rotation) == q
    n = [0.3, 0.9, 0.1]
    n = list(np.array(n) / np.linalg.norm(n))
    w = dio.load_scene(scene(colliders=[{"shape": "plane", "normal": n,
                                         "normalized": True}])).world
    assert w.to_scene()["colliders"][0]["normal"] == n
    with pytest.raises(defsim.InvalidArgumentError, match="unit"):
        dio.load_scene(scene(colliders=[{"shape": "box", "rotation": [2, 0, 0, 0],
                                         "normalized": True}])).world


@pytest.mark.parametrize("quadratic", [False, True])
def test_volume_averaging_key_round_trip(quadratic: bool) -> None:
    """The scene key "volume_averaging" reaches the library (the body steps differently from the
    same body without it) and comes back from World.to_scene; the export loads and steps to the
    same bits. Linear tets (the averaged nodal volume) and quadratic ones (the mean dilatation)."""
    def scene(avg: bool) -> dict:
        body = {"name": "block",
                "mesh": {"type": "box", "lo": [0, 0, 0], "hi": [0.4, 0.1, 0.1], "cells": [4, 1, 1],
                         "quadratic": quadratic},
                "material": {"model": "neohookean", "youngs_modulus": 1e5, "poisson_ratio": 0.49,
                             "density": 500},
                "pin": {"box": {"lo": [0, 0, 0], "hi": [0, 0.1, 0.1]}}}
        if avg:
            body["volume_averaging"] = True
        return {"world": {"backend": "newton_cholmod", "h": 0.01, "duration": 0.1},
                "bodies": [body]}
    a, b = dio.load_scene(scene(True)), dio.load_scene(scene(False))
    exported = a.world.to_scene()
    assert exported["bodies"][0]["volume_averaging"] is True
    assert "volume_averaging" not in b.world.to_scene()["bodies"][0]
    c = dio.load_scene(exported)
    _same_run(a.world, a.step, c.world, c.step, 5)
    for _ in range(5):
        b.step()
    assert np.abs(a.world.positions - b.world.positions).max() > 1e-4


@pytest.mark.parametrize("backend", ["newton_cholmod", "symplectic_euler"])
def test_shell_world_round_trip_is_bit_identical(backend: str, tmp_path) -> None:
    """A world of shells (docs/shells.md) exports its bodies' "shell" objects with the fields
    as given: an orthotropic cloth pinned at one edge with warp/weft bending, and a StVK sheet
    with the plate rigidity; exported after 10 steps, the scene loads back to the same state
    and masses and steps 10 more to the same bits. Its checkpoint loads and continues bit for
    bit too."""
    mesh = defsim.mesh_cloth((0, 0, 0), (0.3, 0, 0), (0, 0, 0.3), 6, 6)
    w = defsim.World(backend=backend, gravity=(0, -9.81, 0), num_threads=1)
    cloth = w.add_body(mesh.positions, triangles=mesh.triangles,
                       shell=defsim.Shell(membrane=defsim.Membrane.ORTHOTROPIC_STVK,
                                          warp_modulus=3000, weft_modulus=1200, shear_modulus=300,
                                          warp_poisson=0.25, warp_direction=(1, 0.2, 0.5),
                                          areal_density=0.15, bending_rigidity=2e-5,
                                          bending_rigidity_weft=5e-6))
    sheet = w.add_body(mesh.positions - [0, 0.1, 0], triangles=mesh.triangles,
                       shell=defsim.Shell(membrane=defsim.Membrane.STVK, youngs_modulus=3e5,
                                          poisson_ratio=0.35, thickness=8e-4))
    edge = np.flatnonzero(mesh.positions[:, 2] == 0.0)
    cloth.pin(edge)
    sheet.pin(edge)
    h = 5e-3 if backend == "newton_cholmod" else 0.9 * w.stable_step()[0]
    w.step(h, steps=10)
    scene = w.to_scene(h=h, duration=1.0)
    shells = [b["shell"] for b in scene["bodies"]]
    assert shells[0]["membrane"] == "orthotropic_stvk" and shells[1]["membrane"] == "stvk"
    assert shells[0]["warp_direction"] == [1, 0.2, 0.5]
    assert shells[0]["bending_rigidity_weft"] == 5e-6 and shells[1]["bending_rigidity"] == -1
    w2 = dio.load_scene(scene).world
    assert _bits(w2.positions) == _bits(w.positions)
    assert _bits(w2.masses) == _bits(w.masses)
    w.save(tmp_path / "shells.dfck")
    w3 = defsim.World.load(tmp_path / "shells.dfck")
    for body in w3.bodies:
        top = w3.topology(body)   # the shells' triangles, read from the checkpoint
        assert top.triangles.tolist() == mesh.triangles.tolist() and not top.lines.size
    x0 = w.positions.copy()
    for i in range(10):
        for world in (w, w2, w3):
            world.step(h)
        for other in (w2, w3):
            assert _bits(other.positions) == _bits(w.positions), f"positions differ, step {i + 1}"
            assert _bits(other.velocities) == _bits(w.velocities), f"velocities, step {i + 1}"
    assert np.abs(w.positions - x0).max() > 1e-5   # the sheets move


def test_contact_thickness_is_exported() -> None:
    """A body's contact_thickness (docs/body-contact.md "Thickness") goes into the scene as
    "contact_thickness" (left out at 0), loads back and steps to the same bits; the layers keep
    their spacing: two 0.4 m cloths of thickness 6 mm dropped on a plane rest 6 mm apart (to
    dhat) and the lower one 3 mm above the plane."""
    w = world_or_skip("newton_cholmod", num_threads=1,
                      options={"core.body_contact": True, "newton_cholmod.tolerance": 1e-9})
    t = 6e-3
    for k, y in enumerate((0.012, 0.024)):
        m = defsim.mesh_cloth((-0.2, y, -0.2), (0.4, 0, 0), (0, 0, 0.4), 4, 4)
        w.add_body(m, material=defsim.Material("spring", stiffness=200, vertex_mass=2e-3,
                                               mass_damping=0.5), contact_thickness=t)
    w.add_body(defsim.mesh_cloth((0.3, 0.05, 0), (0.1, 0, 0), (0, 0, 0.1), 1, 1),
               material=defsim.Material("spring", stiffness=200, vertex_mass=2e-3))
    w.add_collider("plane", friction=0.3)
    scene = w.to_scene(h=1.0 / 60, duration=1.0)
    assert [b.get("contact_thickness") for b in scene["bodies"]] == [t, t, None]
    s = dio.load_scene(scene)
    _same_run(w, lambda: w.step(1.0 / 60), s.world, s.step, 60)
    y = w.positions[:, 1]
    dhat = 1e-3 * float(np.linalg.norm([0.6, 0.05 - 0.012, 0.4]))   # of the rest box
    lower, upper = y[:25], y[25:50]
    assert lower.min() >= t / 2 and lower.max() <= t / 2 + dhat
    gap = upper - lower   # the layers lie flat, vertex above vertex
    assert gap.min() >= t and gap.max() <= t + dhat
