# SPDX-License-Identifier: MIT
"""The .vtu frames of `defsim run` read back with meshio (and with VTK's own reader when the
`vtk` module is importable): every array of every frame, for meshes small enough that every
block length residue and a first or last byte that looks like whitespace occur (1 to 3 cells,
ropes of 1 to 4 segments, a 1 x 1 cloth), quadratic boxes of 1 and 2 cells (VTK_QUADRATIC_TETRA cells, meshio's tetra10), compared with
independent computations:
- displacement = points - points of frame 0, to 1e-12 m;
- pinned = exactly the vertices the scene pins;
- von Mises from the 9-component Cauchy tensor, to 1e-9 relative;
- sum over tets of energy_density x rest volume = the elastic energy of energy.csv, to 1e-9
  relative (tet bodies: the density is per rest volume, and the whole elastic energy is in the
  tets; a quadratic tet's density is its energy over its volume, the volume of its corners' tet
  for these straight elements);
- velocity = the difference quotient of the positions is not asserted (a step is not a frame):
  only its shape and finiteness.
usage: check_vtu_readers.py DEFSIM_EXE SCENES_DIR WORK_DIR
"""
import csv
import json
import os
import subprocess
import sys

import meshio
import numpy as np

try:
    import vtk  # noqa: F401  (optional: VTK's own XML reader)
    from vtk.util.numpy_support import vtk_to_numpy
except ImportError:
    vtk = None

exe, scenes, work = sys.argv[1:4]
failures = []


def check(cond, msg):
    if not cond:
        failures.append(msg)


def run(name, scene, sets):
    out = os.path.join(work, name)
    cmd = [exe, "run", os.path.join(scenes, scene), "--out", out, "--progress", "none"]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True)
    return out


def frames(out):
    return sorted(f for f in os.listdir(out) if f.startswith("frame_") and f.endswith(".vtu"))


def tet_volumes(points, tets):
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)) / 6.0


def vtk_arrays(path):
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    g = r.GetOutput()
    out = {"Points": vtk_to_numpy(g.GetPoints().GetData())}
    for data in (g.GetPointData(), g.GetCellData()):
        for i in range(data.GetNumberOfArrays()):
            out[data.GetArrayName(i)] = vtk_to_numpy(data.GetArray(i))
    return out, g.GetNumberOfCells()


def check_run(name, scene, sets, pinned, quadratic=False):
    out = run(name, scene, sets)
    energy = {int(r["frame"]): float(r["elastic"])
              for r in csv.DictReader(open(os.path.join(out, "energy.csv")))}
    files = frames(out)
    check(len(files) >= 2, f"{name}: {len(files)} frames")
    m0 = meshio.read(os.path.join(out, files[0]))
    for f in files + ["final.vtu"]:
        path = os.path.join(out, f)
        m = meshio.read(path)
        where = f"{name}/{f}"
        pd, cd = m.point_data, m.cell_data
        n = len(m.points)
        check(m.points.shape == m0.points.shape, f"{where}: points {m.points.shape}")
        check(np.all(np.isfinite(m.points)), f"{where}: non-finite points")
        check(pd["velocity"].shape == (n, 3) and np.all(np.isfinite(pd["velocity"])),
              f"{where}: velocity")
        check(np.max(np.abs(pd["displacement"] - (m.points - m0.points))) <= 1e-12,
              f"{where}: displacement is not points - initial points")
        want = np.zeros(n, dtype=np.uint8)
        want[pinned(m0.points)] = 1
        check(np.array_equal(pd["pinned"].reshape(-1), want), f"{where}: pinned flags")
        ncells = sum(len(b.data) for b in m.cells)
        check(len(np.concatenate(cd["body"])) == ncells, f"{where}: body per cell")
        tets = [b.data for b in m.cells if b.type in ("tetra", "tetra10")]
        if quadratic:
            check(all(b.type == "tetra10" and b.data.shape[1] == 10 for b in m.cells),
                  f"{where}: cells {[(b.type, b.data.shape) for b in m.cells]}, not "
                  "VTK_QUADRATIC_TETRA")
        if tets:
            sig = np.concatenate(cd["cauchy_stress"]).reshape(-1, 3, 3)
            vm = np.concatenate(cd["von_mises"]).reshape(-1)
            dev = sig - np.trace(sig, axis1=1, axis2=2)[:, None, None] / 3 * np.eye(3)
            vm_ref = np.sqrt(1.5 * np.einsum("kij,kij->k", dev, dev))
            check(np.allclose(vm, vm_ref, rtol=1e-9, atol=1e-9 * max(1.0, vm_ref.max())),
                  f"{where}: von_mises disagrees with cauchy_stress")
            psi = np.concatenate(cd["energy_density"]).reshape(-1)
            e_tets = float(np.sum(psi * tet_volumes(m0.points, np.concatenate(tets))))
            if f != "final.vtu":
                e = energy[int(f[6:11])]
                check(abs(e_tets - e) <= 1e-9 * max(abs(e), 1e-12),
                      f"{where}: sum psi V = {e_tets}, energy.csv elastic = {e}")
        if vtk is not None:
            arrays, nc = vtk_arrays(path)
            check(nc == ncells, f"{where}: VTK reads {nc} cells, meshio {ncells}")
            for key in ("velocity", "displacement", "pinned"):
                check(np.array_equal(arrays[key].reshape(pd[key].shape), pd[key]),
                      f"{where}: VTK and meshio disagree on {key}")
            check(np.array_equal(arrays["Points"], m.points), f"{where}: VTK points")
            for key in cd:
                check(np.array_equal(arrays[key].reshape(-1),
                                     np.concatenate(cd[key]).reshape(-1)),
                      f"{where}: VTK and meshio disagree on {key}")
    return len(files)


count = 0
short = ["world.duration=0.1"]
for cells in ([1, 1, 1], [2, 1, 1], [3, 1, 1], [1, 2, 1]):
    count += check_run(f"box{''.join(map(str, cells))}", "cantilever.json",
                       short + [f"bodies.0.mesh.cells={json.dumps(cells)}",
                                "bodies.0.probe=0"],
                       lambda x: np.flatnonzero(x[:, 0] == 0.0))   # its pinned x = 0 face
for cells in ([1, 1, 1], [2, 1, 1]):   # quadratic tets: VTK_QUADRATIC_TETRA (24), 10 per cell
    count += check_run(f"quadratic{''.join(map(str, cells))}", "cantilever.json",
                       short + [f"bodies.0.mesh.cells={json.dumps(cells)}",
                                "bodies.0.mesh.quadratic=true", "bodies.0.probe=0"],
                       lambda x: np.flatnonzero(x[:, 0] == 0.0), quadratic=True)
for seg in (1, 2, 3, 4):
    count += check_run(f"rope{seg}", "rope.json",
                       ["world.duration=0.01", "world.frame_steps=10",
                        f"bodies.0.mesh.segments={seg}", "bodies.0.probe=0"], lambda x: [0])
count += check_run("cloth1", "cloth.json",
                   ["world.duration=0.01", "world.frame_steps=10", "bodies.0.mesh.cells=[1,1]",
                    "bodies.0.probe=0", "bodies.0.pin=[0,1]"], lambda x: [0, 1])
print(f"{count} frames read with meshio {meshio.__version__}"
      + (f" and VTK {vtk.vtkVersion.GetVTKVersion()}" if vtk is not None else
         " (VTK's reader: module vtk not importable, not checked)"))
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
