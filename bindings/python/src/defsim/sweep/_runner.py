# SPDX-License-Identifier: MIT
"""One variant in a worker: `defsim run` (or `defsim stress --variant K`) in a subprocess.

A subprocess per variant isolates crashes (a segfault or an abort ends that process, not the
worker) and hangs (a per-variant timeout kills it), and it runs exactly the code that
`defsim run` runs, so a sweep's numbers are those of the command line, bit for bit.
"""
from __future__ import annotations

import base64
import json
import math
import os
import re
import shutil
import signal
import subprocess
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

import numpy as np

from .._cli import find_defsim


def worker_exe(client_exe: str) -> str:
    """The executable a worker runs: the client's if this machine has it at the same path,
    else this machine's own (DEFSIM_EXE, the package's, PATH, a build tree)."""
    return client_exe if os.access(client_exe, os.X_OK) else find_defsim()


def child_env(exe: str) -> Dict[str, str]:
    """The variant's environment: this process's, plus DEFSIM_BACKEND_PATH pointing at the build
    tree's modules when `exe` is a build-tree binary and the variable is not set (an installed
    defsim has its module directory compiled in)."""
    env = dict(os.environ)
    if not env.get("DEFSIM_BACKEND_PATH"):
        modules = Path(exe).resolve().parent.parent / "modules"
        if modules.is_dir():
            env["DEFSIM_BACKEND_PATH"] = str(modules)
    # One thread of OpenMP unless the scene says otherwise (world.threads sets it explicitly).
    env.setdefault("OMP_NUM_THREADS", "1")
    return env


@dataclass
class FinalState:
    """What a metric function receives: the final state of a run (from its final.vtu) and its
    summary (the `defsim run --summary-json` record, a dict)."""
    positions: np.ndarray   # (n, 3), m
    velocities: np.ndarray  # (n, 3), m/s
    time: float             # simulated time, s
    summary: Dict[str, Any]
    overrides: Dict[str, Any]
    folder: str             # the run's output folder (valid during the call)


_ARRAY = re.compile(rb'<DataArray[^>]*Name="([^"]+)"[^>]*offset="(\d+)"')
_TIME = re.compile(rb'Name="TimeValue"[^>]*>([^<]+)<')


def read_vtu(path: str) -> Dict[str, Any]:
    """Points, velocity and time of a .vtu written by `defsim run`: appended Float64 blocks with
    UInt64 byte counts, little-endian, in base64 (each count and each block encoded on its own,
    offsets in characters; as tools/vtk.c writes them) or raw (files of earlier versions)."""
    data = Path(path).read_bytes()
    mark = data.find(b'<AppendedData encoding="base64">')
    encoded = mark >= 0
    if not encoded:
        mark = data.find(b'<AppendedData encoding="raw">')
    if mark < 0 or b'header_type="UInt64"' not in data[:mark]:
        raise ValueError(f"{path}: not a .vtu written by defsim run")
    base = data.index(b"_", mark) + 1
    head = data[:mark]
    if b'byte_order="LittleEndian"' not in head:
        raise ValueError(f"{path}: only little-endian files are read")
    out: Dict[str, Any] = {}
    for name, off in _ARRAY.findall(head):
        if name not in (b"Points", b"velocity"):
            continue
        start = base + int(off)
        if encoded:
            nbytes = int(np.frombuffer(base64.b64decode(data[start:start + 12]), "<u8")[0])
            chars = 4 * ((nbytes + 2) // 3)
            block = base64.b64decode(data[start + 12:start + 12 + chars])
            arr = np.frombuffer(block, dtype="<f8", count=nbytes // 8)
        else:
            nbytes = int(np.frombuffer(data, dtype="<u8", count=1, offset=start)[0])
            arr = np.frombuffer(data, dtype="<f8", count=nbytes // 8, offset=start + 8)
        out[name.decode()] = arr.reshape(-1, 3).copy()
    m = _TIME.search(head)
    out["time"] = float(m.group(1)) if m else math.nan
    if "Points" not in out:
        raise ValueError(f"{path}: no Points array")
    return out


@dataclass
class SceneTask:
    """Everything a worker needs to run one variant of a scene (picklable)."""
    variant_id: str
    overrides: Dict[str, Any]
    scene: str                      # absolute path of the scene file
    out_root: str                   # the sweep's folder; runs go to out_root/runs/<id>
    exe: str
    threads: int = 1
    timeout: Optional[float] = None
    keep_output: bool = False
    vtk: bool = False               # all VTK frames too (final.vtu is always written: --vtk final)
    metrics: Optional[Callable[[FinalState], Any]] = None


def _worker_name() -> str:
    try:
        from distributed import get_worker
        return get_worker().address
    except Exception:   # not inside a Dask worker (a serial run)
        return f"pid{os.getpid()}"


def _run(cmd: List[str], env: Dict[str, str], timeout: Optional[float],
         cwd: Optional[str] = None):
    """(returncode, stdout, stderr, timed_out). The child gets its own process group, so a
    timeout kills whatever it started too."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            start_new_session=True, cwd=cwd)
    try:
        out, err = proc.communicate(timeout=timeout)
        return proc.returncode, out.decode(errors="replace"), err.decode(errors="replace"), False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        return proc.returncode, out.decode(errors="replace"), err.decode(errors="replace"), True


def _exit_status(rc: int, timed_out: bool, stderr: str) -> Dict[str, Any]:
    if timed_out:
        return {"status": "timeout", "message": "killed after the per-variant timeout"}
    if rc < 0:
        try:
            name = signal.Signals(-rc).name
        except ValueError:
            name = "?"
        return {"status": "crashed", "message": f"killed by signal {-rc} ({name})"}
    lines = [ln for ln in stderr.strip().splitlines() if ln.strip()]
    return {"status": "error", "message": lines[-1] if lines else f"exit status {rc}"}


def run_scene_variant(task: SceneTask) -> Dict[str, Any]:
    """Runs one variant and returns its summary row. Never raises for a failed run: a failure
    is a row with its status (unstable, not_converged, error, crashed, timeout, metric_error)."""
    t_start = time.time()
    runs = Path(task.out_root) / "runs"
    final_dir = runs / task.variant_id
    # A private folder per attempt: a retried variant (its worker died) never shares files with
    # an attempt that may still be running.
    work = runs / f".{task.variant_id}.{uuid.uuid4().hex[:8]}"
    work.mkdir(parents=True, exist_ok=True)
    summary_path = work / "summary.json"
    exe = worker_exe(task.exe)
    cmd = [exe, "run", task.scene, "--out", str(work), "--progress", "none",
           "--summary-json", str(summary_path), "--threads", str(int(task.threads))]
    if not task.vtk:
        cmd += ["--vtk", "final"]
    for key, value in task.overrides.items():
        cmd += ["--set", f"{key}={json.dumps(value)}"]
    t0 = time.perf_counter()
    rc, _out, err, timed_out = _run(cmd, child_env(exe), task.timeout)
    run_s = time.perf_counter() - t0
    # The overrides go into the row as JSON text too, so the Parquet files alone say what ran.
    row: Dict[str, Any] = {"variant_id": task.variant_id, "returncode": rc, "run_s": run_s,
                           "worker": _worker_name(), "message": "",
                           "overrides": json.dumps(task.overrides, sort_keys=True)}
    summary: Dict[str, Any] = {}
    if summary_path.is_file() and not timed_out and rc >= 0:
        try:
            summary = json.loads(summary_path.read_text())
        except ValueError:   # cut short (a full disk): the run's stderr says more
            summary = {}
    if summary:
        row["status"] = str(summary["status"]).replace(" ", "_")
        row["message"] = summary.get("message", "")
        if rc not in (0, 1, 130):
            row["status"], row["message"] = "error", f"exit status {rc}: {row['message']}"
    else:
        row.update(_exit_status(rc, timed_out, err))
    row.update(_summary_columns(summary))
    if task.metrics is not None and summary:
        try:
            vtu = read_vtu(str(work / "final.vtu"))
            state = FinalState(vtu["Points"], vtu.get("velocity", np.zeros_like(vtu["Points"])),
                               vtu["time"], summary, dict(task.overrides), str(work))
            row.update(_metric_columns(task.metrics(state)))
        except Exception as exc:   # the user's function: its failure is this row's status
            row["status"], row["message"] = "metric_error", f"{type(exc).__name__}: {exc}"
    if task.keep_output:
        if final_dir.exists():
            shutil.rmtree(final_dir, ignore_errors=True)
        os.replace(work, final_dir)
        row["output"] = str(final_dir)
    else:
        shutil.rmtree(work, ignore_errors=True)
        row["output"] = ""
    row["t_start"], row["t_end"] = t_start, time.time()
    return row


def _num(v: Any) -> float:
    return math.nan if v is None else float(v)


def _summary_columns(s: Mapping[str, Any]) -> Dict[str, Any]:
    end = s.get("energy_end", {})
    cols: Dict[str, Any] = {
        "steps": int(s.get("steps", 0)), "failed_steps": int(s.get("failed_steps", 0)),
        "frames": int(s.get("frames", 0)), "sim_time": _num(s.get("time")),
        "wall_s": _num(s.get("wall")), "stable_step": _num(s.get("stable_step")),
        "E_start": _num(s.get("energy_start", {}).get("total")),
        "E_kinetic": _num(end.get("kinetic")), "E_elastic": _num(end.get("elastic")),
        "E_gravitational": _num(end.get("gravitational")), "E_total": _num(end.get("total")),
    }
    for p in s.get("probes", []):
        for axis, value in zip("xyz", p["position"]):
            cols[f"probe{p['body']}_{axis}"] = _num(value)
    return cols


def _metric_columns(result: Any) -> Dict[str, Any]:
    """A metric function returns a number (column `metric`) or a dict of named numbers or
    strings (columns `metric_<name>`)."""
    if isinstance(result, Mapping):
        return {f"metric_{k}": (v if isinstance(v, str) else float(v)) for k, v in result.items()}
    return {"metric": float(result)}


@dataclass
class ToolTask:
    """One run of `defsim stress` or `defsim bench` (`--variant K`): its CSV header and row."""
    variant_id: str
    index: int
    exe: str
    tool: str
    args: Sequence[str]
    timeout: Optional[float] = None
    cwd: Optional[str] = None       # the client's folder, where relative paths in args point
    backend: str = ""               # the run's backend in the client's listing


def run_tool_variant(task: ToolTask) -> Dict[str, Any]:
    """Runs `defsim TOOL ARGS --variant K`; the row keeps the tool's CSV header and line as
    text (`csv_header`, `csv_row`: the last two lines it prints) so the sweep can write the
    tool's own CSV unchanged."""
    t_start = time.time()
    exe = worker_exe(task.exe)
    cmd = [exe, task.tool, *task.args, "--variant", str(task.index)]
    t0 = time.perf_counter()
    cwd = task.cwd if task.cwd and os.path.isdir(task.cwd) else None
    rc, out, err, timed_out = _run(cmd, child_env(exe), task.timeout, cwd)
    run_s = time.perf_counter() - t0
    lines = [ln for ln in out.splitlines() if ln.strip()]
    row: Dict[str, Any] = {"variant_id": task.variant_id, "index": task.index, "returncode": rc,
                           "run_s": run_s, "worker": _worker_name(), "t_start": t_start,
                           "csv_header": "", "csv_row": "", "message": err.strip()[-2000:]}
    # With --check a stress violation exits 1 and still prints its row.
    printed = rc == 0 or (task.tool == "stress" and rc == 1)
    if len(lines) >= 2 and not timed_out and printed:
        row["csv_header"], row["csv_row"] = lines[-2], lines[-1]
        row["status"] = "ok" if rc == 0 else "violation"
        # A worker that lacks a backend module numbers the runs differently: its row is not
        # the listed run.
        fields = dict(zip(lines[-2].split(","), lines[-1].split(",")))
        if task.backend and fields.get("backend") != task.backend:
            row.update(status="mismatch", csv_header="", csv_row="",
                       message=f"run {task.index} here is {fields.get('backend')!r}, listed as "
                               f"{task.backend!r} (are the same backend modules on every "
                               "worker?)")
    else:
        row.update(_exit_status(rc, timed_out, err))
    row["t_end"] = time.time()
    return row


def run_guarded(task: Any, run: Callable[[Any], Dict[str, Any]]) -> Dict[str, Any]:
    """run(task), or an `error` row if the worker itself fails (no executable there, a full
    disk): a failing variant never ends the sweep."""
    try:
        return run(task)
    except Exception as exc:
        now = time.time()
        row: Dict[str, Any] = {"variant_id": task.variant_id, "status": "error",
                               "returncode": -1, "message": f"worker: {type(exc).__name__}: {exc}",
                               "worker": _worker_name(), "t_start": now, "t_end": now}
        if isinstance(task, ToolTask):
            row.update(index=task.index, csv_header="", csv_row="")
        return row
