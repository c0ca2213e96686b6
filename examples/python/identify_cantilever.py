# SPDX-License-Identifier: MIT
"""Identification: Young's modulus and mass damping of the cantilever from its tip trajectory.

The cantilever of tests/scenes/cantilever.json (3 m x 1 m x 1 m, stable neo-Hookean, nu = 0.3,
1000 kg/m^3, clamped at x = 0, sagging under gravity from rest) is simulated with the true
E = 1 MPa and alpha = 1 /s, on a 6 x 2 x 2-cell mesh with newton_cholmod (h = 1/60 s, 60 steps).
The tip corner's trajectory (3, 1, 1) over the run is the observation. Starting from
E = 0.5 MPa and alpha = 0.3 /s, scipy's L-BFGS-B minimises

    L(E, alpha) = sum_s |tip_s(E, alpha) - tip_s^obs|^2 / sum_s |tip_s^obs - tip_0|^2

with the gradient of each run from one recording and one backward pass (world.record(),
tape.backward()). The parameters are optimised in log scale. The script prints every iteration
and writes identify_cantilever.csv and, with matplotlib, identify_cantilever.png (the loss
against the iteration). Before exiting 0 it checks that E and alpha are recovered to 1e-3
relative within 40 iterations.

    python identify_cantilever.py [--quick] [--out DIR]

--quick is accepted for the tests and changes nothing: the run is already small.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys

import numpy as np

try:
    from scipy.optimize import minimize
except ImportError:   # the example is about scipy's L-BFGS-B
    print("identify_cantilever: needs scipy (pip install scipy)", file=sys.stderr)
    sys.exit(77)

import defsim

E_TRUE, ALPHA_TRUE = 1e6, 1.0
E0, ALPHA0 = 5e5, 0.3
H, STEPS = 1.0 / 60.0, 60
MESH = defsim.mesh_box((0, 0, 0), (3, 1, 1), cells=(6, 2, 2))
TIP = int(np.argmin(np.linalg.norm(MESH.positions - np.array([3.0, 1.0, 1.0]), axis=1)))


def world(E: float, alpha: float) -> defsim.World:
    w = defsim.World("newton_cholmod", gravity=(0, -9.81, 0), num_threads=1,
                     options={"newton_cholmod.tolerance": 1e-12})
    b = w.add_body(MESH, material=defsim.Material("stable_neohookean", youngs_modulus=E,
                                                  poisson_ratio=0.3, density=1000.0,
                                                  mass_damping=alpha))
    w.pin(b, MESH.positions[:, 0] == 0.0)
    return w


def trajectory(w: defsim.World) -> np.ndarray:
    out = [w.positions[TIP].copy()]
    for _ in range(STEPS):
        w.step(H)
        out.append(w.positions[TIP].copy())
    return np.array(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="accepted for the tests (no change)")
    ap.add_argument("--out", default=".", help="folder for the CSV and the plot")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    with world(E_TRUE, ALPHA_TRUE) as w:
        observed = trajectory(w)
    scale = float(np.sum((observed - observed[0]) ** 2))
    history = []

    def loss_and_grad(theta: np.ndarray):
        E, alpha = E0 * np.exp(theta[0]), ALPHA0 * np.exp(theta[1])
        with world(E, alpha) as w:
            tape = w.record()
            tip = trajectory(w)
            r = tip - observed
            dL_dx = np.zeros((STEPS + 1, w.vertex_count, 3))
            dL_dx[:, TIP, :] = 2.0 * r / scale
            g = tape.backward(dL_dx=dL_dx, params=["youngs_modulus", "mass_damping"])
            tape.close()
        L = float(np.sum(r * r) / scale)
        grad = np.array([g["youngs_modulus"][0] * E, g["mass_damping"][0] * alpha])
        history.append((len(history), E, alpha, L))
        print(f"evaluation {len(history):3d}: E = {E:.9e} Pa  alpha = {alpha:.9f} /s  "
              f"loss = {L:.6e}")
        return L, grad

    res = minimize(loss_and_grad, np.zeros(2), jac=True, method="L-BFGS-B",
                   options={"maxiter": 40, "ftol": 1e-16, "gtol": 1e-12})
    E, alpha = E0 * np.exp(res.x[0]), ALPHA0 * np.exp(res.x[1])
    eE, ea = abs(E - E_TRUE) / E_TRUE, abs(alpha - ALPHA_TRUE) / ALPHA_TRUE
    print(f"L-BFGS-B: {res.nit} iterations, {res.nfev} evaluations ({res.message})")
    print(f"recovered E = {E:.9e} Pa (true {E_TRUE:.3e}, relative error {eE:.2e}), "
          f"alpha = {alpha:.9f} /s (true {ALPHA_TRUE}, relative error {ea:.2e})")

    with open(os.path.join(args.out, "identify_cantilever.csv"), "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["evaluation", "youngs_modulus", "mass_damping", "loss"])
        wr.writerows(history)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.semilogy([h[0] for h in history], [max(h[3], 1e-300) for h in history], "o-")
        ax.set_xlabel("evaluation (L-BFGS-B)")
        ax.set_ylabel("loss")
        ax.set_title("identifying E and alpha of the cantilever")
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, "identify_cantilever.png"), dpi=120)
    except ImportError:
        print("matplotlib missing: no plot")

    ok = eE <= 1e-3 and ea <= 1e-3 and res.nit <= 40
    if not ok:
        print("FAILED: E and alpha not recovered to 1e-3 within 40 iterations", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
