# SPDX-License-Identifier: MIT
"""Spreading variants over Dask and collecting their rows into Parquet as they arrive."""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
import time
import uuid
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Mapping, Optional, Sequence, Union

import pandas as pd

from ._runner import (SceneTask, ToolTask, find_defsim, run_guarded, run_scene_variant,
                      run_tool_variant)
from ._variants import dedupe

RESULTS = "results"   # DIR/results/part-*.parquet


def read_results(out: Union[str, os.PathLike]) -> pd.DataFrame:
    """Every row a sweep in `out` has written, one per variant id (parts written by a run that
    was stopped are included; a variant written twice, which only a resume racing another run
    could do, keeps its first row)."""
    parts = sorted((Path(out) / RESULTS).glob("part-*.parquet"))
    if not parts:
        return pd.DataFrame({"variant_id": pd.Series(dtype=str)})
    # Parts are read one by one: a column that only later variants have (a metric that failed
    # earlier) would not fit one dataset schema.
    df = pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True, sort=False)
    return df.drop_duplicates("variant_id", keep="first").reset_index(drop=True)


class _PartWriter:
    """Buffers rows and writes them as one Parquet file per batch (through a temporary name and
    a rename, so a reader never sees half a file)."""

    def __init__(self, folder: Path, batch: int, interval: float):
        self.folder, self.batch, self.interval = folder, batch, interval
        self.folder.mkdir(parents=True, exist_ok=True)
        self.rows: List[Dict[str, Any]] = []
        self.last = time.monotonic()
        self.tag = uuid.uuid4().hex[:8]
        self.count = 0

    def add(self, row: Dict[str, Any]) -> None:
        self.rows.append(row)
        if len(self.rows) >= self.batch or time.monotonic() - self.last >= self.interval:
            self.flush()

    def flush(self) -> None:
        self.last = time.monotonic()
        if not self.rows:
            return
        name = f"part-{time.strftime('%Y%m%dT%H%M%S')}-{self.tag}-{self.count:05d}.parquet"
        tmp = self.folder / f".{name}.tmp"
        pd.DataFrame(self.rows).to_parquet(tmp, index=False)
        os.replace(tmp, self.folder / name)
        self.count += 1
        self.rows = []


@contextlib.contextmanager
def _client(client: Any, scheduler: Optional[str], workers: Optional[int]) -> Iterator[Any]:
    """The given client; or one connected to `scheduler`; or an embedded LocalCluster of
    `workers` processes with one thread each (a variant is a subprocess: threads would add
    nothing, and processes keep a worker's death to itself)."""
    if client is not None:
        yield client
        return
    from distributed import Client, LocalCluster
    if scheduler:
        with Client(scheduler) as c:
            yield c
        return
    n = workers or os.cpu_count() or 1
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


class _Progress:
    """tqdm when it is installed and wanted, else one line per tenth of the sweep."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.n, self.enabled, self.bar = total, 0, enabled, None
        if enabled:
            try:
                from tqdm import tqdm
                self.bar = tqdm(total=total, unit="variant", file=sys.stderr)
            except ImportError:
                pass

    def update(self, status: str) -> None:
        self.n += 1
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix_str(status)
        elif self.enabled and (self.n == self.total or self.n % max(1, self.total // 10) == 0):
            print(f"  {self.n}/{self.total} variants", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _manifest(out: Path, what: Dict[str, Any], resume: bool) -> None:
    """DIR/sweep.json records what the folder holds; a resume must sweep the same thing."""
    path = out / "sweep.json"
    if path.exists():
        old = json.loads(path.read_text())
        if old != what:
            raise ValueError(f"{out} holds a sweep of something else ({old}); use another folder")
        if not resume and (out / RESULTS).exists() and any((out / RESULTS).glob("part-*")):
            raise ValueError(f"{out} already has results: pass resume=True (--resume) to add "
                             "the missing variants, or use another folder")
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(what, indent=1) + "\n")


def _execute(tasks: Sequence[Any], func: Callable[[Any], Dict[str, Any]], out: Path,
             client: Any, scheduler: Optional[str], workers: Optional[int],
             max_variants: Optional[int], progress: bool, batch: int,
             flush_interval: float, on_row: Optional[Callable[[Dict[str, Any]], None]]
             ) -> List[str]:
    """Submits the tasks, writes rows as they come; returns the ids that ran."""
    ran: List[str] = []
    if not tasks:
        return ran
    writer = _PartWriter(out / RESULTS, batch, flush_interval)
    bar = _Progress(len(tasks) if max_variants is None else min(len(tasks), max_variants),
                    progress)
    with _client(client, scheduler, workers) as c:
        from distributed import as_completed
        # The key is the variant id: Dask runs a key once, and reschedules it when a worker dies
        # before returning its result. A token per call keeps a client that is reused between
        # calls from handing back a result of an earlier call.
        token = uuid.uuid4().hex[:8]
        futures = c.map(run_guarded, tasks, run=func,
                        key=[f"defsim-variant-{t.variant_id}-{token}" for t in tasks])
        seen = set()
        try:
            for fut, row in as_completed(futures, with_results=True):
                if row["variant_id"] in seen:
                    continue
                seen.add(row["variant_id"])
                row["t_received"] = time.time()
                writer.add(row)
                ran.append(row["variant_id"])
                bar.update(row["status"])
                if on_row is not None:
                    on_row(row)
                if max_variants is not None and len(ran) >= max_variants:
                    break
        finally:
            # Whatever stops the loop (max_variants, Ctrl-C, an error): keep what arrived.
            writer.flush()
            bar.close()
            c.cancel(futures)
    return ran


def run_sweep(scene: Union[str, os.PathLike, Mapping[str, Any]],
              variants: Sequence[Mapping[str, Any]], out: Union[str, os.PathLike], *,
              metrics: Optional[Callable[[Any], Any]] = None, client: Any = None,
              scheduler: Optional[str] = None, workers: Optional[int] = None,
              resume: bool = False, keep_output: bool = False, vtk: bool = False,
              threads: int = 1, timeout: Optional[float] = 3600.0, exe: Optional[str] = None,
              max_variants: Optional[int] = None, progress: bool = False, batch: int = 8,
              flush_interval: float = 2.0,
              on_row: Optional[Callable[[Dict[str, Any]], None]] = None) -> pd.DataFrame:
    """Runs every variant of `scene` (a scene file, or a scene as a dict) on Dask and returns
    one row per variant as a DataFrame (also in `out`/results/*.parquet, written as rows arrive).

    variants: overrides at dotted scene keys, e.g. from `grid(...)` or `samples(...)`.
    metrics: a function of the final state (a `FinalState`) returning a number or a dict of
        numbers, run in the worker after the variant; its columns are `metric` / `metric_<name>`.
    client / scheduler / workers: a `distributed.Client`, a scheduler address
        ("tcp://host:8786"), or the size of an embedded LocalCluster (default: the CPU count).
    resume: skip variants whose ids `out` already holds. keep_output: keep each variant's
        folder (out/runs/<id>: final.vtu, energy.csv, summary.json; with vtk=True all frames).
    threads: world.threads of every variant (1: comparable, deterministic timings).
    timeout: seconds after which a variant is killed (status "timeout"); None: never.
    max_variants: stop after this many variants have finished (the rest stay for a resume).
    The returned frame has `attrs["ran"]`, the ids that ran in this call."""
    out = Path(out).resolve()
    exe = find_defsim(exe)
    if isinstance(scene, Mapping):
        # A scene given as a dict is written to the folder (once the folder is known to hold
        # this sweep); its mesh files, if any, must be absolute paths or relative to `out`.
        data = json.dumps(scene, indent=1, sort_keys=True).encode()
        scene_path = out / "scene.json"
    else:
        scene_path = Path(scene).resolve()
        data = scene_path.read_bytes()
    scene_hash = hashlib.sha256(data).hexdigest()[:16]
    items = dedupe(variants)
    _manifest(out, {"kind": "scene", "scene": str(scene_path), "scene_sha256": scene_hash},
              resume)
    if isinstance(scene, Mapping):
        scene_path.write_bytes(data)
    done = set(read_results(out)["variant_id"]) if resume else set()
    tasks = [SceneTask(vid, ov, str(scene_path), str(out), exe, threads, timeout, keep_output,
                       vtk, metrics) for vid, ov in items if vid not in done]
    ran = _execute(tasks, run_scene_variant, out, client, scheduler, workers, max_variants,
                   progress, batch, flush_interval, on_row)
    df = read_results(out)
    if not df.empty:
        wanted = {vid: i for i, (vid, _) in enumerate(items)}
        df = df[df["variant_id"].isin(wanted)].copy()
        # One column per swept key, first; rows in the order of the variants.
        by_id = dict(items)
        keys = list(dict.fromkeys(k for _, ov in items for k in ov))
        swept = pd.DataFrame({k: [by_id[v].get(k) for v in df["variant_id"]] for k in keys},
                             index=df.index)
        df = pd.concat([swept, df.drop(columns=[k for k in keys if k in df.columns])], axis=1)
        df = df.sort_values("variant_id", key=lambda s: s.map(wanted)).reset_index(drop=True)
    df.attrs["ran"] = ran
    return df


def list_tool_variants(tool: str, args: Sequence[str], exe: Optional[str] = None
                       ) -> List[Dict[str, Any]]:
    """`defsim TOOL ARGS --list-variants`: the tool's runs, one dict each (with "index")."""
    import subprocess
    from ._runner import child_env
    exe = find_defsim(exe)
    proc = subprocess.run([exe, tool, *args, "--list-variants"], capture_output=True, text=True,
                          env=child_env(exe))
    if proc.returncode != 0:
        raise RuntimeError(f"defsim {tool} --list-variants failed ({proc.returncode}): "
                           f"{proc.stderr.strip()}")
    # Other lines are the tool's own report (the bench's reference).
    return [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{")]


def run_tool_sweep(tool: str, args: Sequence[str], out: Union[str, os.PathLike], *,
                   client: Any = None, scheduler: Optional[str] = None,
                   workers: Optional[int] = None, resume: bool = False,
                   timeout: Optional[float] = 3600.0, exe: Optional[str] = None,
                   max_variants: Optional[int] = None, progress: bool = False,
                   batch: int = 32, flush_interval: float = 2.0) -> pd.DataFrame:
    """The runs of `defsim TOOL ARGS` (`stress` or `bench`: tools with --list-variants and
    --variant K) spread over Dask. The listing runs first, here (the bench computes or loads its
    reference there, once). Returns one row per run, in the tool's order, with the tool's
    settings and its CSV line; `write_tool_csv` writes the CSV the serial tool would have
    written (stress), `finish_bench` the bench's CSV, Pareto table and plot."""
    out = Path(out).resolve()
    exe = find_defsim(exe)
    listed = list_tool_variants(tool, args, exe)
    ids = [hashlib.sha256(json.dumps(v, sort_keys=True).encode()).hexdigest()[:16] for v in listed]
    _manifest(out, {"kind": "tool", "tool": tool, "args": list(args)}, resume)
    done = set(read_results(out)["variant_id"]) if resume else set()
    tasks = [ToolTask(vid, int(v["index"]), exe, tool, list(args), timeout, os.getcwd(),
                      str(v.get("backend", "")))
             for vid, v in zip(ids, listed) if vid not in done]
    ran = _execute(tasks, run_tool_variant, out, client, scheduler, workers, max_variants,
                   progress, batch, flush_interval, None)
    df = read_results(out)
    if not df.empty:
        order = {vid: i for i, vid in enumerate(ids)}
        df = df[df["variant_id"].isin(order)].copy()
        df = df.sort_values("variant_id", key=lambda s: s.map(order)).reset_index(drop=True)
        settings = pd.DataFrame([listed[order[v]] for v in df["variant_id"]])
        df = pd.concat([settings.drop(columns=["index"]), df], axis=1)
    df.attrs["ran"] = ran
    df.attrs["variants"] = len(listed)
    return df


def write_tool_csv(df: pd.DataFrame, path: Union[str, os.PathLike]) -> None:
    """The tool's CSV from a tool sweep's rows: its header, then its rows in the tool's order.
    Raises ValueError if a run has no row (it crashed or timed out: see `status`)."""
    bad = df[df["csv_row"] == ""]
    if len(bad):
        raise ValueError(f"{len(bad)} runs have no CSV row: indices {list(bad['index'])[:10]}")
    headers = set(df["csv_header"])
    if len(headers) != 1:
        raise ValueError(f"the runs printed different CSV headers: {sorted(headers)}")
    with open(path, "w") as f:
        f.write(headers.pop() + "\n")
        for line in df.sort_values("index")["csv_row"]:
            f.write(line + "\n")


def finish_bench(df: pd.DataFrame, args: Sequence[str], rows_path: Union[str, os.PathLike],
                 exe: Optional[str] = None) -> str:
    """Writes the rows of a bench sweep to `rows_path` and runs `defsim bench ARGS --rows FILE`,
    which writes the CSV (with its Pareto column), the Pareto table and the plot exactly as the
    serial bench does, from these rows. Returns the bench's output (its table)."""
    import subprocess
    from ._runner import child_env
    write_tool_csv(df, rows_path)
    exe = find_defsim(exe)
    proc = subprocess.run([exe, "bench", *args, "--rows", str(rows_path)], capture_output=True,
                          text=True, env=child_env(exe))
    if proc.returncode != 0:
        raise RuntimeError(f"defsim bench --rows failed ({proc.returncode}): "
                           f"{proc.stderr.strip()}")
    return proc.stdout
