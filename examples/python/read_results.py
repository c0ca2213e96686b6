# SPDX-License-Identifier: MIT
"""Reading results back: a cantilever released under gravity is written as a VTK series
(defsim.io.Series: .vtu frames and a .pvd), then read with meshio as any post-processing script
would, and plotted with matplotlib (Agg, no display): tip deflection and the largest von Mises
stress against time.

Checks before exiting 0: the frames read back hold exactly the positions the world had (float64
round trip), their times are those of the .pvd, and the tip's downward swing is the largest
deflection, where the root's stress peaks too.

    pip install 'defsim-fem[io]' matplotlib
    python read_results.py [--quick] [--out DIR]
"""
from __future__ import annotations

import argparse
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

import defsim
import defsim.io


def simulate(folder: str, frames: int) -> np.ndarray:
    """Runs the beam, writing frames; returns the final positions."""
    mesh = defsim.mesh_box((0, 0, 0), (1.0, 0.1, 0.1), cells=(10, 2, 2))
    with defsim.World("symplectic_euler", gravity=(0, -9.81, 0), num_threads=1) as world:
        beam = world.add_body(mesh, material=defsim.Material(
            "stable_neohookean", youngs_modulus=5e6, poisson_ratio=0.3, density=500))
        world.pin(beam, mesh.positions[:, 0] == 0.0)
        with defsim.io.Series(folder, name="beam") as series:
            series.write(world)
            for _ in range(frames):
                world.step(1e-4, steps=200)      # 20 ms per frame
                series.write(world)
        return world.positions


def read_series(pvd: str):
    """(times, meshio meshes) of the frames a .pvd lists, in order."""
    import meshio
    root = ET.parse(pvd).getroot()
    entries = [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]
    folder = os.path.dirname(pvd)
    return ([t for t, _ in entries], [meshio.read(os.path.join(folder, f)) for _, f in entries])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="15 frames only (for the test)")
    ap.add_argument("--out", default="read_results_out", help="output folder")
    args = ap.parse_args()
    try:
        import meshio  # noqa: F401  (the reader this example is about)
    except ImportError:
        print("SKIP: meshio is not installed (pip install 'defsim-fem[io]')")
        return 77
    frames = 15 if args.quick else 50
    final = simulate(args.out, frames)

    times, meshes = read_series(os.path.join(args.out, "beam.pvd"))
    tip = meshes[0].points[:, 0] == 1.0
    deflection = np.array([-m.point_data["displacement"][tip, 1].mean() for m in meshes])
    vm = np.array([np.concatenate(m.cell_data["von_mises"]).max() for m in meshes])
    for t, d, s in zip(times, deflection, vm):
        print(f"t = {t:5.3f} s  tip deflection {d * 1e3:7.2f} mm  max von Mises {s / 1e3:8.2f} kPa")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(6, 5))
        a.plot(times, deflection * 1e3)
        a.set_ylabel("tip deflection (mm)")
        b.plot(times, vm / 1e3, color="C3")
        b.set_ylabel("max von Mises (kPa)")
        b.set_xlabel("time (s)")
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, "beam.png"), dpi=100)
    except ImportError:
        print("matplotlib not installed: no plot")

    failures = []
    if not np.array_equal(meshes[-1].points, final):
        failures.append("the last frame does not hold the final positions")
    if not (len(times) == frames + 1 and np.all(np.diff(times) > 0)):
        failures.append(f"times {times}")
    for m, t in zip(meshes, times):
        if float(m.field_data["TimeValue"][0]) != t:
            failures.append(f"frame at {t}: TimeValue {m.field_data['TimeValue']}")
    if not (deflection[0] == 0.0 and deflection.max() > 0.0):
        failures.append(f"deflections {deflection}")
    if abs(int(np.argmax(vm)) - int(np.argmax(deflection))) > 1:
        failures.append("stress and deflection peak at different frames")
    if failures:
        sys.exit("FAILED: " + "\n        ".join(failures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
