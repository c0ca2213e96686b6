# SPDX-License-Identifier: MIT
"""defsim.sweep on a real LocalCluster of 2 workers: results equal to `defsim run` bit for bit,
failures as rows, a worker killed mid-sweep, resume, the stress tool, the CLI."""
from __future__ import annotations

import json
import math
import os
import signal
import stat
import subprocess
from pathlib import Path

import numpy as np
import pytest

# Skipped, with the reason (pytest -rs), only where the sweep extras are missing.
_EXTRAS = "pip install './bindings/python[sweep]'"
pytest.importorskip("distributed", reason=f"dask.distributed is not installed: {_EXTRAS}")
pd = pytest.importorskip("pandas", reason=f"pandas is not installed: {_EXTRAS}")
pytest.importorskip("pyarrow", reason=f"pyarrow is not installed: {_EXTRAS}")

from defsim.sweep import (finish_bench, grid, read_results, read_vtu, run_sweep,
                          run_tool_sweep, samples, variant_id, write_tool_csv)
from defsim.sweep._cli import main as cli_main  # noqa: E402

E = "bodies.0.material.youngs_modulus"
# Step sizes that divide a 1/30 s frame (the scene's fps) into whole steps.
H = [1 / 2400, 1 / 1800, 1 / 1200, 1 / 960]
SHORT = {"world.duration": 0.1}


def test_variants_grid_samples_ids():
    g = grid({"a": [1, 2, 3], "b": ["x", "y"]})
    assert g == [{"a": a, "b": b} for a in (1, 2, 3) for b in ("x", "y")]
    s1 = samples({"e": (1e4, 1e8, "log"), "nu": (0.2, 0.45), "k": (1, 3, "int")}, 200, seed=7)
    assert s1 == samples({"e": (1e4, 1e8, "log"), "nu": (0.2, 0.45), "k": (1, 3, "int")}, 200,
                         seed=7)
    e = np.array([v["e"] for v in s1])
    assert e.min() >= 1e4 and e.max() <= 1e8
    # Log-uniform: about half the samples below the geometric middle, 1e6.
    assert 70 < (e < 1e6).sum() < 130
    assert {v["k"] for v in s1} == {1, 2, 3}
    assert variant_id({"a": 1.0, "b": 2}) == variant_id({"b": 2, "a": 1.0})
    assert variant_id({"a": 1.0}) != variant_id({"a": 1.5})
    assert len({variant_id(v) for v in g}) == 6


def test_a_failing_worker_call_is_an_error_row():
    from defsim.sweep._runner import SceneTask, ToolTask, run_guarded

    def boom(task):
        raise OSError("no space left on device")

    row = run_guarded(SceneTask("abc", {}, "s.json", "/nonexistent", "defsim"), boom)
    assert row["variant_id"] == "abc" and row["status"] == "error"
    assert "OSError" in row["message"]
    row = run_guarded(ToolTask("t1", 7, "defsim", "stress", []), boom)
    assert row["index"] == 7 and row["csv_row"] == "" and row["status"] == "error"


def test_a_tool_run_numbered_otherwise_on_a_worker_is_refused(exe):
    from defsim.sweep._runner import ToolTask, run_tool_variant
    args = ["--reduced", "--scenes", "rope", "--backends", "symplectic_euler", "--steps", "10"]
    assert run_tool_variant(ToolTask("a", 3, exe, "stress", args,
                                     backend="symplectic_euler"))["status"] == "ok"
    # As if the client had listed explicit_euler at index 3 and this worker lacked it.
    row = run_tool_variant(ToolTask("a", 3, exe, "stress", args, backend="explicit_euler"))
    assert row["status"] == "mismatch" and row["csv_row"] == ""


def _serial_tip(exe, scene, overrides, out):
    """The probe (tip) of `defsim run` with the same overrides and threads, from its final.vtu."""
    cmd = [exe, "run", str(scene), "--out", str(out), "--progress", "none", "--vtk", "final",
           "--threads", "1"]
    for k, v in overrides.items():
        cmd += ["--set", f"{k}={json.dumps(v)}"]
    subprocess.run(cmd, check=True, capture_output=True)
    return read_vtu(str(out / "final.vtu"))["Points"]


def test_twelve_variants_equal_defsim_run_bit_for_bit(client, exe, cantilever, tmp_path):
    variants = [{**v, **SHORT} for v in grid({E: [1e5, 1e6, 1e7], "world.h": H})]
    df = run_sweep(cantilever, variants, tmp_path / "sweep", client=client, exe=exe,
                   metrics=lambda s: {"tip_y": s.positions[324, 1],
                                      "min_y": s.positions[:, 1].min()})
    assert len(df) == 12 and list(df["status"]) == ["ok"] * 12
    assert sorted(df.attrs["ran"]) == sorted(variant_id(v) for v in variants)
    for i, v in enumerate(variants):
        x = _serial_tip(exe, cantilever, v, tmp_path / f"serial{i}")
        row = df.iloc[i]
        assert row[E] == v[E] and row["world.h"] == v["world.h"]
        assert row["steps"] == round(0.1 / v["world.h"])
        # Bit for bit: the summary's 17 digits and the metric read from final.vtu.
        assert (row["probe0_x"], row["probe0_y"], row["probe0_z"]) == tuple(x[324])
        assert row["metric_tip_y"] == x[324, 1] and row["metric_min_y"] == x[:, 1].min()
    # Every variant ended somewhere else: the overrides reached the runs.
    assert len(set(df["probe0_y"])) == 12


def _wrapper(tmp_path, exe):
    """A `defsim` that segfaults when its arguments say "crash" and hangs when they say "hang":
    real signals and real hangs, to check that they stay inside their variant."""
    path = tmp_path / "defsim-wrapper"
    modules = Path(exe).resolve().parent.parent / "modules"   # as the sweep gives the real one
    path.write_text("#!/bin/sh\ncase \"$*\" in\n  *crash*) kill -SEGV $$ ;;\n"
                    "  *hang*) exec sleep 60 ;;\nesac\n"
                    f"export DEFSIM_BACKEND_PATH=${{DEFSIM_BACKEND_PATH:-{modules}}}\n"
                    f"exec {exe} \"$@\"\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def test_failures_are_rows_and_the_sweep_goes_on(client, exe, cantilever, tmp_path):
    ok = {**SHORT, "world.h": 1 / 1200}
    variants = [
        ok,
        {**SHORT, E: 1e7, "world.h": 1 / 300},                     # blows up (explicit limit)
        {**SHORT, "world.backend": "newton_cholmod", "world.max_iterations": 1,
         "world.tolerance": 1e-12, "world.h": 1 / 30},              # Newton gives up
        {**SHORT, E: -1.0},                                         # the scene is refused
        {**SHORT, "description": "crash"},                          # segfaults
        {**SHORT, "description": "hang"},                           # killed after the timeout
        {**SHORT, "world.h": 1 / 2400},
    ]
    df = run_sweep(cantilever, variants, tmp_path / "s", client=client,
                   exe=_wrapper(tmp_path, exe), timeout=4.0)
    assert list(df["status"]) == ["ok", "unstable", "not_converged", "error", "crashed",
                                  "timeout", "ok"]
    unstable = df.iloc[1]
    assert 0 < unstable["steps"] < 30 and unstable["failed_steps"] == 1
    # The predicted stable step says why: h was above it.
    assert unstable["stable_step"] < 1 / 300
    assert df.iloc[2]["steps"] == 0 and "Newton" in df.iloc[2]["message"]
    assert "youngs_modulus" in df.iloc[3]["message"]
    assert df.iloc[4]["returncode"] == -signal.SIGSEGV
    assert 4.0 <= df.iloc[5]["run_s"] < 30
    assert df.iloc[6]["steps"] == 240


def test_worker_killed_mid_sweep_loses_nothing(client, exe, cantilever, tmp_path):
    pids = client.run(os.getpid)   # worker address -> pid
    killed = {}

    def kill_busy_worker(row):
        if killed:
            return
        busy = [w for w, keys in client.processing().items() if keys]
        if busy:
            killed["address"], killed["keys"] = busy[0], client.processing()[busy[0]]
            os.kill(pids[busy[0]], signal.SIGKILL)

    # Each variant about 0.2 s of stepping, so the kill lands while one runs.
    variants = [{"world.duration": 0.5, "world.h": 1 / 2400, E: e}
                for e in np.geomspace(2e5, 5e6, 16)]
    df = run_sweep(cantilever, variants, tmp_path / "k", client=client, exe=exe,
                   on_row=kill_busy_worker)
    assert killed and killed["keys"], "no worker was busy when a row arrived"
    with pytest.raises(OSError):
        os.kill(pids[killed["address"]], 0)   # that process is gone
    assert len(df) == 16 and df["variant_id"].is_unique
    assert set(df["variant_id"]) == {variant_id(v) for v in variants}
    assert (df["status"] == "ok").all() and (df["steps"] == 1200).all()
    # What the dead worker held was run again by another one.
    lost = {k.split("-")[2] for k in killed["keys"]}
    rerun = df[df["variant_id"].isin(lost)]
    assert len(rerun) == len(lost) and (rerun["worker"] != killed["address"]).any()
    # The table on disk is complete and unduplicated too.
    disk = read_results(tmp_path / "k")
    assert len(disk) == 16 and disk["variant_id"].is_unique


def test_resume_runs_only_the_missing_variants(client, exe, cantilever, tmp_path):
    variants = [{**SHORT, "world.h": h, E: e} for h in H for e in (1e6, 3e6)]
    first = run_sweep(cantilever, variants, tmp_path / "r", client=client, exe=exe,
                      max_variants=3, batch=1)
    assert len(first) == 3 and len(first.attrs["ran"]) == 3
    with pytest.raises(ValueError, match="resume"):
        run_sweep(cantilever, variants, tmp_path / "r", client=client, exe=exe)
    second = run_sweep(cantilever, variants, tmp_path / "r", client=client, exe=exe,
                       resume=True)
    all_ids = {variant_id(v) for v in variants}
    assert set(second.attrs["ran"]) == all_ids - set(first.attrs["ran"])
    assert len(second.attrs["ran"]) == 5
    assert len(second) == 8 and set(second["variant_id"]) == all_ids
    # Nothing left: a third call runs nothing.
    third = run_sweep(cantilever, variants, tmp_path / "r", client=client, exe=exe, resume=True)
    assert third.attrs["ran"] == [] and len(third) == 8


def test_scene_as_a_dict(client, exe, cantilever, tmp_path):
    scene = json.loads(cantilever.read_text())
    scene["world"]["duration"] = 0.1
    variants = [{E: 1e6}, {E: 2e6}]
    df = run_sweep(scene, variants, tmp_path / "d", client=client, exe=exe)
    assert list(df["status"]) == ["ok", "ok"] and list(df.columns[:1]) == [E]
    assert json.loads((tmp_path / "d" / "scene.json").read_text()) == scene
    # The Parquet rows alone say what ran.
    disk = read_results(tmp_path / "d").set_index("variant_id")
    assert [json.loads(disk.loc[variant_id(v), "overrides"]) for v in variants] == variants
    # Another scene in the same folder is refused, and the folder's scene stays.
    other = {**scene, "world": {**scene["world"], "duration": 0.2}}
    with pytest.raises(ValueError, match="something else"):
        run_sweep(other, variants, tmp_path / "d", client=client, exe=exe, resume=True)
    assert json.loads((tmp_path / "d" / "scene.json").read_text()) == scene


def test_stress_through_the_engine_equals_the_serial_tool(client, exe, tmp_path):
    args = ["--reduced", "--scenes", "rope", "--backends", "symplectic_euler", "--steps", "100"]
    serial = tmp_path / "serial.csv"
    subprocess.run([exe, "stress", *args, "--csv", str(serial)], check=True,
                   capture_output=True)
    df = run_tool_sweep("stress", args, tmp_path / "t", client=client, exe=exe)
    assert len(df) == df.attrs["variants"] == 60 and (df["status"] == "ok").all()
    write_tool_csv(df, tmp_path / "sweep.csv")
    assert (tmp_path / "sweep.csv").read_text() == serial.read_text()
    # Both outcomes occur in this matrix, so equality means something: stable runs, and runs
    # whose blow-up the watchdog refuses (a clean error: docs/watchdog.md).
    classes = set(df["csv_row"].str.split(",").str[6])
    assert {"stable", "clean_error"} <= classes


def test_bench_through_the_engine_matches_the_serial_bench(client, exe, tmp_path):
    rope = Path(__file__).resolve().parents[4] / "tests" / "scenes" / "rope.json"
    common = [str(rope), "--backends", "symplectic_euler,newton_cholmod,sundials_ida",
              "--h", "2e-4,4e-4,8e-4", "--tol", "1e-4,1e-6", "--time", "0.05", "--repeats", "1",
              "--no-plot"]
    serial = subprocess.run([exe, "bench", *common, "--out", str(tmp_path / "serial")],
                            capture_output=True, text=True)
    if serial.returncode or "skipped" in serial.stdout:
        pytest.skip(f"the bench needs sundials_ida and newton_cholmod: {serial.stderr.strip()}")
    args = [*common, "--out", str(tmp_path / "dist")]
    df = run_tool_sweep("bench", args, tmp_path / "t", client=client, exe=exe)
    assert len(df) == 8 and (df["status"] == "ok").all()
    finish_bench(df, args, tmp_path / "rows.csv", exe=exe)
    a = pd.read_csv(tmp_path / "serial" / "rope.csv")
    b = pd.read_csv(tmp_path / "dist" / "rope.csv")
    # Everything but the timings (taken concurrently here) and the Pareto flags that follow
    # from them is the same: errors, statuses and counts are deterministic.
    same = ["backend", "kind", "value", "rms_err", "max_err", "energy_err", "status", "steps",
            "newton_iterations", "internal_steps"]
    pd.testing.assert_frame_equal(a[same], b[same])
    # The assembled CSV marks as Pareto-optimal exactly the points no other beats in both.
    for i, r in b.iterrows():
        dominated = ((b["wall_s"] <= r["wall_s"]) & (b["rms_err"] <= r["rms_err"]) &
                     ((b["wall_s"] < r["wall_s"]) | (b["rms_err"] < r["rms_err"]))).any()
        assert r["pareto"] == int(not dominated)
    assert (tmp_path / "dist" / "rope_pareto.md").is_file()


def test_cli_local_scheduler_and_plot(cluster, exe, cantilever, tmp_path, capsys):
    out = tmp_path / "cli"
    rc = cli_main([str(cantilever), "--out", str(out), "--scheduler", cluster.scheduler_address,
                   "--grid", f"{E}=1e6,1e7", "--grid", "world.h=0.0008333333333333334,"
                   "0.0033333333333333335", "--grid", "world.duration=0.1", "--exe", exe,
                   "--plot", "--no-progress"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "3 ok, 1 unstable (4 variants)" in text
    assert (out / "sweep.png").stat().st_size > 5000
    df = read_results(out)
    assert len(df) == 4
    bad = df[df["status"] == "unstable"]
    assert len(bad) == 1 and math.isclose(bad.iloc[0]["stable_step"], 0.001446, rel_tol=0.05)


def test_cli_without_a_defsim_names_its_flag(cantilever, tmp_path, monkeypatch, capsys):
    # Issue 28, 1: with no defsim to find (a wheel without one, nothing on PATH), the message
    # named `exe=...`, the Python argument, where the command line's flag is --exe; and it came
    # only after a local cluster had started.
    from defsim import _cli
    monkeypatch.delenv("DEFSIM_EXE", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    monkeypatch.setattr(_cli, "_source_builds", lambda: [])
    monkeypatch.setattr(_cli, "bundled_defsim", lambda: None)
    rc = cli_main([str(cantilever), "--out", str(tmp_path / "o"), "--workers", "1",
                   "--grid", "world.duration=0.05", "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "no defsim executable: pass --exe PATH" in err and "exe=" not in err.replace("--exe", "")
    assert not (tmp_path / "o").exists()   # refused before anything ran
    with pytest.raises(FileNotFoundError, match=r"pass exe=PATH"):
        run_sweep(str(cantilever), [{}], tmp_path / "p", workers=1)
