# SPDX-License-Identifier: MIT
"""defsim.view / World.view (libdefsim_view) on a Python world, under Xvfb (ctest
test_python_view, registered only when the viewer is built: CMake says when it is not)."""
import os
import subprocess
import sys

import numpy as np
import pytest

import defsim

H = 1e-3
STEPS_PER_FRAME = 5


def beam_world():
    mesh = defsim.mesh_box((0, 0, 0), (1, 0.2, 0.2), cells=(10, 2, 2))
    world = defsim.World(backend="symplectic_euler", gravity=(0, -9.81, 0), num_threads=1)
    beam = world.add_body(mesh, material=defsim.Material(
        "corotated", youngs_modulus=1e5, poisson_ratio=0.3, density=1000, mass_damping=2.0))
    world.pin(beam, mesh.positions[:, 0] == 0.0)
    return world


def script(tmp_path, text):
    p = tmp_path / "script.txt"
    p.write_text(text)
    return str(p)


def test_drag_pulls_the_vertex_toward_the_cursor(tmp_path):
    """The free end dragged 100 pixels up: the spring's target lies above the grabbed vertex
    (the camera's up is +y), the vertex ends near it, far above where the same world stepped
    without the drag puts it, and the attachment is gone afterwards."""
    world = beam_world()
    s = script(tmp_path, "timing off\npause\nstep 20\nplay\n"
                         "drag 505 230 -> 505 130 over 40 frames\n"
                         f"screenshot {tmp_path / 'pulled.png'}\nrelease\n")
    r = defsim.view(world, H, steps_per_frame=STEPS_PER_FRAME, width=640, height=400, script=s)
    assert r.steps == 20 + 40 * STEPS_PER_FRAME
    assert r.drag_vertex is not None
    start, target, end = (np.array(v) for v in (r.drag_start, r.drag_target, r.drag_end))
    d = target - start
    # Screen up is world up tilted by the camera's 20 degree elevation (tan 20 = 0.36).
    assert d[1] > 0.1 and d[1] > 2.0 * np.hypot(d[0], d[2])
    assert np.linalg.norm(end - target) < 0.3 * np.linalg.norm(start - target)
    # The world keeps the state at the release, without the pulling spring.
    assert len(world.attachments()) == 0
    assert np.allclose(world.positions[r.drag_vertex], end)
    twin = beam_world()
    twin.step(H, steps=r.steps)
    assert end[1] - twin.positions[r.drag_vertex][1] > 0.1
    assert (tmp_path / "pulled.png").stat().st_size > 1000
    world.close()
    twin.close()


def test_world_view_and_reset(tmp_path):
    """World.view is defsim.view; reset restores the positions and velocities of the start."""
    world = beam_world()
    x0 = world.positions.copy()
    s = script(tmp_path, "pause\nstep 30\nexpect steps == 30\nreset\n"
                         "expect vertex.0.x == 0\nexpect drag.vertex == -1\n")
    r = world.view(H, script=s)
    assert (r.steps, r.expectations, r.expectations_failed) == (30, 3, 0)
    assert np.array_equal(world.positions, x0)
    assert np.array_equal(world.velocities, np.zeros_like(x0))
    world.close()


def test_failed_expectations_are_counted(tmp_path):
    world = beam_world()
    r = world.view(H, script=script(tmp_path, "step 5\nexpect steps > 5\nexpect time > 0\n"))
    assert (r.expectations, r.expectations_failed) == (2, 1)
    world.close()


def test_bad_arguments(tmp_path):
    world = beam_world()
    with pytest.raises(defsim.InvalidArgumentError):
        world.view(0.0)
    with pytest.raises(defsim.InvalidArgumentError):
        world.view(H, color="pink")
    with pytest.raises(defsim.InvalidArgumentError, match=r"script.txt:2: "):
        world.view(H, script=script(tmp_path, "step 1\ndrag 1 2 to 3 4\n"))
    with pytest.raises(defsim.InvalidArgumentError, match="unknown quantity"):
        world.view(H, script=script(tmp_path, "expect speed > 1\n"))
    with pytest.raises(defsim.FileError):
        world.view(H, script=str(tmp_path / "missing.txt"))
    with pytest.raises(defsim.InvalidArgumentError, match="no vertex within"):
        world.view(H, script=script(tmp_path, "press 2 2\n"))
    assert world.time == 0.0
    world.close()


def test_no_display_is_backend_unavailable(tmp_path):
    """Without a display the call raises BackendUnavailableError (in a child without DISPLAY)."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    code = ("import defsim, sys\n"
            "w = defsim.World(backend='symplectic_euler')\n"
            "w.add_body(defsim.mesh_box((0, 0, 0), (1, 1, 1), cells=(1, 1, 1)),\n"
            "           material=defsim.Material('corotated', youngs_modulus=1e5,\n"
            "                                    poisson_ratio=0.3, density=1000))\n"
            "try:\n"
            "    w.view(1e-3)\n"
            "except defsim.BackendUnavailableError as e:\n"
            "    print('unavailable:', e); sys.exit(0)\n"
            "sys.exit(3)\n")
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "no display" in p.stdout
