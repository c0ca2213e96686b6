# SPDX-License-Identifier: MIT
"""Material study: one cantilever, four hyperelastic models, tip deflection against tip load.

A 1 m x 0.1 m x 0.1 m beam (E = 1 MPa, nu = 0.3), clamped at x = 0, carries a downward load
spread over its tip face. Each load is solved quasi-statically: implicit Euler (newton_cholmod)
with large steps (0.5 s) converges to the static equilibrium, since the inertia term vanishes
as the state stops changing. Writes material_study.csv and, with matplotlib, material_study.png.

What it shows, and checks before exiting 0:
  * at small loads all four models give the same deflection (they share the linearisation at
    rest; within 0.5 %) and the deflection is linear in the load (within 0.5 %);
  * at large loads they part: the secant compliance (deflection / load) drops as the beam
    bends (geometric stiffening of a cantilever under a vertical tip load).
Euler-Bernoulli's F L^3 / (3 E I) is printed alongside: linear tets on this coarse mesh are
stiffer than the beam theory (shear locking), which a finer mesh reduces. The models part by
less than 1 % up to 60 N (StVK the stiffest, neo-Hookean the most compliant): a cantilever's
large deflection is large rotation at small strain, where all four agree; they differ where
the strain is large (compression, stretching a block), not here. The plot's right panel shows
the deflections relative to the co-rotated model.

    python material_study.py [--quick] [--out DIR]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import defsim

MODELS = ["stvk", "corotated", "neohookean", "stable_neohookean"]
L, H, W, E, NU = 1.0, 0.1, 0.1, 1e6, 0.3


def tip_deflection(model: str, load: float, mesh: defsim.Mesh, tip: np.ndarray) -> float:
    with defsim.World("newton_cholmod", gravity=(0, 0, 0), num_threads=1) as world:
        beam = world.add_body(mesh, material=defsim.Material(
            model, youngs_modulus=E, poisson_ratio=NU, density=100))
        world.pin(beam, mesh.positions[:, 0] == 0.0)
        f = np.zeros((mesh.vertex_count, 3))
        f[tip, 1] = -load / tip.size
        world.set_external_forces(f)
        previous = None
        for _ in range(60):
            world.step(0.5)
            d = float(mesh.positions[tip, 1].mean() - world.positions[tip, 1].mean())
            if previous is not None and abs(d - previous) <= 1e-9 * abs(d):
                return d
            previous = d
    raise RuntimeError(f"{model} at {load} N did not settle")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="three loads only (for the test)")
    ap.add_argument("--out", default=".", help="folder for the CSV and the plot")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    loads = [0.5, 1.0, 40.0] if args.quick else [0.5, 1.0, 5.0, 10.0, 20.0, 40.0, 60.0]
    mesh = defsim.mesh_box((0, 0, 0), (L, H, W), cells=(10, 2, 2))
    tip = np.flatnonzero(mesh.positions[:, 0] == L)
    d = {m: [tip_deflection(m, F, mesh, tip) for F in loads] for m in MODELS}

    inertia = W * H ** 3 / 12
    with open(os.path.join(args.out, "material_study.csv"), "w") as f:
        f.write("load_N,euler_bernoulli_m," + ",".join(f"{m}_m" for m in MODELS) + "\n")
        for i, F in enumerate(loads):
            eb = F * L ** 3 / (3 * E * inertia)
            f.write(f"{F:g},{eb:.6g}," + ",".join(f"{d[m][i]:.9g}" for m in MODELS) + "\n")
            print(f"{F:6g} N: " + "  ".join(f"{m} {d[m][i] * 1e3:8.3f} mm" for m in MODELS) +
                  f"  (Euler-Bernoulli {eb * 1e3:.3f} mm)")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, (ax, rel) = plt.subplots(1, 2, figsize=(10, 4))
        for m in MODELS:
            ax.plot(loads, np.array(d[m]) * 1e3, marker="o", label=m)
            rel.plot(loads, (np.array(d[m]) / np.array(d["corotated"]) - 1) * 100, marker="o",
                     label=m)
        top = max(max(v) for v in d.values()) * 1e3
        ax.plot(loads, [F * L ** 3 / (3 * E * inertia) * 1e3 for F in loads], "k--", lw=0.8,
                label="Euler-Bernoulli (linear)")
        ax.set_ylim(0, 1.1 * top)
        ax.set_xlabel("tip load (N)")
        ax.set_ylabel("tip deflection (mm)")
        ax.set_title("Cantilever, E = 1 MPa, 10 x 2 x 2 cells")
        ax.legend()
        rel.set_xlabel("tip load (N)")
        rel.set_ylabel("deflection against co-rotated (%)")
        rel.set_title("Where the models part")
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, "material_study.png"), dpi=100)
    except ImportError:
        print("matplotlib not installed: no plot")

    failures = []
    small = np.array([d[m][0] for m in MODELS])
    if small.max() - small.min() > 5e-3 * small.mean():
        failures.append(f"small-load deflections differ: {small}")
    for m in MODELS:
        if abs(d[m][1] / d[m][0] - loads[1] / loads[0]) > 5e-3 * loads[1] / loads[0]:
            failures.append(f"{m}: not linear at small loads ({d[m][0]}, {d[m][1]})")
        if not d[m][-1] / loads[-1] < 0.97 * d[m][0] / loads[0]:
            failures.append(f"{m}: no geometric stiffening at {loads[-1]} N")
    if failures:
        sys.exit("FAILED: " + "\n        ".join(failures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
