# SPDX-License-Identifier: MIT
"""The command line the package carries: `defsim` / ``python -m defsim`` run the C tool (found
as find_defsim says), and the shipped scenes (defsim.scenes)."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

import defsim.scenes
from defsim import _cli


def _exe_or_skip() -> str:
    exe = os.environ.get("DEFSIM_EXE")
    if not exe:
        pytest.skip("needs the build's defsim (DEFSIM_EXE, set by ctest when the tools are built)")
    return exe


def _executable(path, text: str = "#!/bin/sh\nexit 0\n") -> str:
    path.write_text(text)
    path.chmod(0o755)
    return str(path)


def test_find_defsim_order_and_message(tmp_path, monkeypatch) -> None:
    monkeypatch.delenv("DEFSIM_EXE", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    monkeypatch.setattr(_cli, "_source_builds", lambda: [])
    monkeypatch.setattr(_cli, "_PKG_DIR", tmp_path / "pkg")
    with pytest.raises(FileNotFoundError) as e:
        _cli.find_defsim()
    assert "pass exe=PATH" in str(e.value)
    with pytest.raises(FileNotFoundError) as e:
        _cli.find_defsim(option="--exe PATH")
    assert "pass --exe PATH" in str(e.value) and "exe=" not in str(e.value).replace("--exe", "")
    # The console script that pip writes for `defsim` is on PATH: not taken (it would run
    # itself); a native one on PATH is.
    bindir = tmp_path / "bin"
    bindir.mkdir()
    _executable(bindir / "defsim", "#!/venv/bin/python\nimport sys\nfrom defsim._cli import "
                                   "main\nsys.exit(main())\n")
    monkeypatch.setenv("PATH", str(bindir))
    with pytest.raises(FileNotFoundError):
        _cli.find_defsim()
    native = _executable(bindir / "defsim", "\x7fELF not really\n")
    assert _cli.find_defsim() == native
    # The package's own (a wheel's defsim/bin/defsim) comes before PATH ...
    (tmp_path / "pkg" / "bin").mkdir(parents=True)
    bundled = _executable(tmp_path / "pkg" / "bin" / "defsim")
    assert _cli.find_defsim() == bundled
    # ... and after DEFSIM_EXE and exe=, which must exist.
    other = _executable(tmp_path / "other")
    monkeypatch.setenv("DEFSIM_EXE", other)
    assert _cli.find_defsim() == other
    assert _cli.find_defsim(native) == native
    with pytest.raises(FileNotFoundError):
        _cli.find_defsim(str(tmp_path / "missing"))


def test_python_m_defsim_is_the_c_tool(tmp_path) -> None:
    exe = _exe_or_skip()
    env = dict(os.environ)
    v = subprocess.run([sys.executable, "-m", "defsim", "--version"], env=env,
                       capture_output=True, text=True, timeout=120)
    ref = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=120)
    assert v.returncode == 0 and v.stdout == ref.stdout and defsim.__version__ in v.stdout
    # A run of a shipped scene: the same summary as the tool's own (but the wall times).
    summaries = []
    for i, cmd in enumerate(([sys.executable, "-m", "defsim"], [exe])):
        out = tmp_path / str(i)
        r = subprocess.run(cmd + ["run", defsim.scenes.path("cantilever"), "--set",
                                  "world.duration=0.05", "--out", str(out), "--summary-json",
                                  str(tmp_path / f"{i}.json")],
                           env=env, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        with open(tmp_path / f"{i}.json") as f:
            summaries.append({k: v for k, v in json.load(f).items()
                              if k not in ("wall", "time_step")})
    assert summaries[0] == summaries[1]
    assert summaries[0]["status"] == "ok" and summaries[0]["probes"][0]["position"][1] < 1.0
    # The tool's exit status and messages come through (an unknown command).
    bad = subprocess.run([sys.executable, "-m", "defsim", "no-such-command"], env=env,
                         capture_output=True, text=True, timeout=120)
    ref = subprocess.run([exe, "no-such-command"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == ref.returncode != 0 and bad.stderr == ref.stderr


def test_shipped_scenes() -> None:
    names = defsim.scenes.names()
    assert {"cantilever", "cloth", "rope", "cloth_sphere"} <= set(names)
    assert names == sorted(names)
    p = defsim.scenes.path("cantilever")
    assert os.path.isfile(p) and p.endswith("cantilever.json")
    assert defsim.scenes.path("cantilever.json") == p
    with open(p) as f:
        assert json.load(f)["bodies"][0]["name"] == "beam"
    with pytest.raises(FileNotFoundError) as e:
        defsim.scenes.path("cantilver")
    assert "did you mean cantilever" in str(e.value)
    with pytest.raises(FileNotFoundError):
        defsim.scenes.path(os.path.join("..", "scenes", "cantilever"))
    # Every shipped scene loads (defsim.io's loader, the one `defsim run` uses).
    import defsim.io as dio
    try:
        dio._scene_lib()
    except OSError as exc:   # no libdefsim_scene in this build
        pytest.skip(f"defsim.io: {exc}")
    for name in names:
        assert dio.load_scene(defsim.scenes.path(name)).world.vertex_count > 0, name


def test_python_m_defsim_scenes() -> None:
    r = subprocess.run([sys.executable, "-m", "defsim.scenes"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.split() == defsim.scenes.names()
    r = subprocess.run([sys.executable, "-m", "defsim.scenes", "cloth"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == defsim.scenes.path("cloth")
    r = subprocess.run([sys.executable, "-m", "defsim.scenes", "nope"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 1 and "no scene 'nope'" in r.stderr
