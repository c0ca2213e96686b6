#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""contact_vs_ipctk.py DIR...: body contact's phases against IPC Toolkit's on the same states.

Each DIR holds states written by `defsim-bench-contact-phases --out DIR` (run.txt names its
impact and settled steps). For each state the script runs our phase benchmark
(`defsim-bench-contact-phases --time DIR --step K`) and IPC Toolkit's
(`ipc_probe.py DIR K REPS`) alternately for ROUNDS rounds, one thread each
(OMP_NUM_THREADS=1), and prints a table phase | ipctk ms | ours ms | ratio (ours / ipctk) of the
medians over the rounds (each round's figure is itself a median of REPS repeats), then the
counts of both.

Environment:
  IPCTK_PYTHON  a Python with ipctk 1.6.1 and numpy (required). Setup, as
                ../shared/peers/contact/README.md says:
                  python3 -m venv venv && venv/bin/pip install ipctk==1.6.1 numpy
                then IPCTK_PYTHON=$PWD/venv/bin/python
  IPC_PROBE     ipc_probe.py (default: ../shared/peers/contact/ipc_probe.py beside the checkout,
                or /work/shared/peers/contact/ipc_probe.py)
  DEFSIM_BUILD  the build folder (default: build); DEFSIM_BACKEND_PATH defaults to its modules
  ROUNDS        alternating rounds (default 3); REPS: repeats per round (default 5)
  STATES        which states of run.txt: "impact settled" (default) or one of them
"""
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# (label, ipctk key, our key)
PHASES = [
    ("broad phase, barrier candidates (ipctk LBVH)", "cand_LBVH", "cand"),
    ("broad phase (ipctk's fastest of 4)", "cand_best", "cand"),
    ("constraint set from the candidates", "collisions_from_cand", "collisions_from_cand"),
    ("energy", "energy", "energy"),
    ("gradient", "gradient", "gradient"),
    ("Hessian with PSD projection", "hessian_psd", "hessian_psd"),
    ("CCD, additive, with its broad phase", "ccd_accd_full", "ccd_accd_full"),
    ("CCD narrow phase alone", "ccd_accd_narrow", "ccd_accd_narrow"),
]
COUNTS = ["candidates", "collisions", "vv_ev_ee_fv", "ccd_candidates", "alpha_accd"]


def probe_path():
    p = os.environ.get("IPC_PROBE")
    if p:
        return p
    for c in (os.path.join(ROOT, "..", "shared", "peers", "contact", "ipc_probe.py"),
              "/work/shared/peers/contact/ipc_probe.py"):
        if os.path.exists(c):
            return c
    sys.exit("contact_vs_ipctk: set IPC_PROBE to ipc_probe.py")


def json_line(cmd, env):
    out = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"contact_vs_ipctk: {' '.join(cmd)} failed:\n{out.stderr}")
    lines = [l for l in out.stdout.splitlines() if l.startswith("{")]
    if not lines:
        sys.exit(f"contact_vs_ipctk: no JSON line from {' '.join(cmd)}")
    return json.loads(lines[-1])


def read_run(d):
    run = {}
    with open(os.path.join(d, "run.txt")) as fh:
        for line in fh:
            k, v = line.split(None, 1)
            run[k] = v.strip()
    return run


def main():
    dirs = sys.argv[1:]
    if not dirs or dirs[0].startswith("-"):
        sys.exit(__doc__)
    py = os.environ.get("IPCTK_PYTHON")
    if not py:
        sys.exit("contact_vs_ipctk: set IPCTK_PYTHON to a Python with ipctk 1.6.1 (see --help)")
    build = os.environ.get("DEFSIM_BUILD", os.path.join(ROOT, "build"))
    ours = os.path.join(build, "bin", "defsim-bench-contact-phases")
    rounds = int(os.environ.get("ROUNDS", "3"))
    reps = os.environ.get("REPS", "5")
    states = os.environ.get("STATES", "impact settled").split()
    env = dict(os.environ, OMP_NUM_THREADS="1")
    env.setdefault("DEFSIM_BACKEND_PATH", os.path.join(build, "modules"))
    probe = probe_path()
    print(f"OMP_NUM_THREADS=1, {rounds} alternating rounds of {reps} repeats each, "
          "process CPU time, medians; ratio = ours / ipctk\n")
    for d in dirs:
        run = read_run(d)
        for which in states:
            step = int(run[which])
            theirs, mine = [], []
            for _ in range(rounds):
                mine.append(json_line([ours, "--time", d, "--step", str(step), "--repeat", reps],
                                      env))
                t = json_line([py, probe, d, str(step), reps], env)
                t["cand_best"] = min(t[k] for k in t if k.startswith("cand_") and
                                     not k.startswith("cand_ccd_"))
                theirs.append(t)
            cells = run.get("cells", "?")
            print(f"### {d}: {cells} x {cells} cells, {which} state (step {step}), "
                  f"{mine[0]['nv']} vertices\n")
            print("| phase | ipctk ms | ours ms | ratio |\n|---|---:|---:|---:|")
            for label, tk, ok in PHASES:
                tv = [r[tk] for r in theirs if r.get(tk) is not None]
                ov = [r[ok] for r in mine if r.get(ok) is not None]
                tm = statistics.median(tv) if tv else None
                om = statistics.median(ov) if ov else None
                ratio = f"{om / tm:.2f}" if tm and om is not None else "n/a"
                fmt = lambda v: "n/a" if v is None else f"{v:.3g}"
                print(f"| {label} | {fmt(tm)} | {fmt(om)} | {ratio} |")
            best = min((k for k in theirs[0] if k.startswith("cand_") and
                        not k.startswith("cand_ccd_") and k != "cand_best"),
                       key=lambda k: theirs[0][k])
            print(f"\nipctk's fastest broad phase in round 1: {best[5:]}. Counts "
                  "(ours: pairs before merging; a vertex-triangle pair counts as fv):")
            for k in COUNTS:
                print(f"- {k}: ipctk {theirs[0].get(k)}, ours {mine[0].get(k)}")
            print(f"- our peak resident memory: {mine[0]['peak_rss_mb']} MB\n")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
