#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Throughput of defsim.sweep: a 48-variant sweep of a scene on a LocalCluster against the same
48 `defsim run` commands one after another, median of repeats; and the engine's overhead per
variant, measured two ways:

- gap: on each worker, the time between the end of one variant and the start of the next (Dask
  handing over the next task and the row going back), averaged over the sweep;
- round trip: one variant submitted at a time; the time from submit to result on the client
  minus the variant's own time inside the task.

    PYTHONPATH=bindings/python/src DEFSIM_LIBRARY=build/libdefsim.so \\
        python tools/bench_sweep.py tests/scenes/cantilever.json --workers 2
"""
from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--variants", type=int, default=48)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--duration", type=float, default=0.5, help="world.duration of each variant")
    ap.add_argument("--round-trips", type=int, default=20)
    ap.add_argument("--exe")
    a = ap.parse_args()

    import numpy as np
    from distributed import Client, LocalCluster

    from defsim.sweep import find_defsim, run_sweep
    from defsim.sweep._runner import SceneTask, child_env, run_scene_variant
    exe = find_defsim(a.exe)
    scene = str(Path(a.scene).resolve())
    E = "bodies.0.material.youngs_modulus"
    variants = [{"world.duration": a.duration, E: float(e)}
                for e in np.geomspace(3e5, 3e6, a.variants)]
    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep_"))
    try:
        serial, swept, gaps = [], [], []
        t0 = time.perf_counter()
        cluster = LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        startup = time.perf_counter() - t0
        env = child_env(exe)
        for r in range(a.repeats):
            # Serial: the commands a shell loop would run.
            t0 = time.perf_counter()
            for i, v in enumerate(variants):
                cmd = [exe, "run", scene, "--out", str(tmp / f"serial{i}"), "--progress", "none",
                       "--vtk", "final", "--threads", "1"]
                for k, x in v.items():
                    cmd += ["--set", f"{k}={json.dumps(x)}"]
                subprocess.run(cmd, check=True, capture_output=True, env=env)
            serial.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            df = run_sweep(scene, variants, tmp / f"sweep{r}", client=client, exe=exe,
                           batch=len(variants))
            swept.append(time.perf_counter() - t0)
            assert len(df) == len(variants) and (df["status"] == "ok").all()
            for _, g in df.sort_values("t_start").groupby("worker"):
                gaps += list(g["t_start"].values[1:] - g["t_end"].values[:-1])
            print(f"repeat {r + 1}: serial {serial[-1]:.2f} s, sweep {swept[-1]:.2f} s "
                  f"(mean variant {df['run_s'].mean() * 1e3:.0f} ms in its subprocess)",
                  flush=True)
        # Round trips of single variants.
        trips = []
        for i in range(a.round_trips):
            task = SceneTask(f"rt{i}", variants[i % len(variants)], scene, str(tmp / "rt"), exe)
            t0 = time.time()
            row = client.submit(run_scene_variant, task, pure=False).result()
            trips.append((time.time() - t0) - (row["t_end"] - row["t_start"]))
        client.close()
        cluster.close()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    ms, mw = statistics.median(serial), statistics.median(swept)
    print(f"\n{a.variants} variants of {Path(scene).name} (world.duration {a.duration} s), "
          f"{a.workers} workers, median of {a.repeats}:")
    print(f"  serial `defsim run` x {a.variants}: {ms:.2f} s")
    print(f"  sweep on the LocalCluster:      {mw:.2f} s  -> speed-up {ms / mw:.2f}x")
    print(f"  cluster start (once):           {startup:.2f} s (not included above)")
    print(f"  engine overhead per variant: gap between tasks on a worker median "
          f"{statistics.median(gaps) * 1e3:.1f} ms (mean {statistics.mean(gaps) * 1e3:.1f} ms, "
          f"{len(gaps)} gaps); round trip minus run time median "
          f"{statistics.median(trips) * 1e3:.1f} ms ({len(trips)} trips)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
