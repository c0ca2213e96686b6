# SPDX-License-Identifier: MIT
"""Cloth dropped on a sphere: a 1 m square cloth (springs by kind: stretch, shear, bend) falls
from 0.4 m above a fixed, rough sphere collider (radius 0.3 m, friction coefficient 1), drapes
over it and comes to rest. Writes a VTK series (defsim.io) and, when libdefsim_render is built, a PNG of the last
state (the same picture Jupyter shows for a World).

Checks before exiting 0, at the end of the run:
  * no cloth vertex is inside the sphere (beyond 1 % of its radius);
  * the cloth's centre rests on the top of the sphere (within 2 cm);
  * the sphere carries the cloth: the vertical contact forces, averaged over 0.1 s, sum to its
    weight within 10 % (it is nearly at rest and only the sphere touches it).

    python cloth_on_sphere.py [--quick] [--out DIR]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import defsim
import defsim.display
import defsim.io

RADIUS, MASS, G = 0.3, 0.2, 9.81


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="a coarser cloth (for the test)")
    ap.add_argument("--out", default="cloth_on_sphere_out", help="output folder")
    args = ap.parse_args()
    n = 12 if args.quick else 30
    cloth = defsim.mesh_cloth((-0.5, RADIUS + 0.4, -0.5), (1, 0, 0), (0, 0, 1), n, n)
    centre = (n // 2) * (n + 1) + n // 2
    with defsim.World("symplectic_euler", gravity=(0, -G, 0), num_threads=1) as world:
        world.add_body(cloth, material=defsim.Material(
            "spring", stiffness=400.0, vertex_mass=MASS / cloth.vertex_count, mass_damping=1.0),
            shear_stiffness=100.0, bend_stiffness=2.0)
        world.add_collider("sphere", radius=RADIUS, friction=1.0)
        with defsim.io.Series(args.out, name="cloth") as series:
            series.write(world)
            for _ in range(40):                       # 2 s in frames of 50 ms
                world.step(2e-4, steps=250)
                series.write(world)
        # Contact forces of single steps flicker as vertices touch and leave: average 0.1 s.
        support = 0.0
        for _ in range(500):
            world.step(2e-4)
            support += world.contact_forces()[:, 1].sum() / 500
        x = world.positions
        if defsim.display.available():
            with open(os.path.join(args.out, "cloth.png"), "wb") as f:
                f.write(defsim.display.render_png(world))

    r = np.linalg.norm(x, axis=1)
    print(f"closest vertex to the centre: {r.min():.4f} m (radius {RADIUS} m); cloth centre at "
          f"y = {x[centre, 1]:.4f} m; mean vertical contact force {support:.4f} N "
          f"(weight {MASS * G:.4f} N)")
    failures = []
    if r.min() < 0.99 * RADIUS:
        failures.append(f"a vertex is inside the sphere: {r.min()}")
    if abs(x[centre, 1] - RADIUS) > 0.02:
        failures.append(f"the centre is not on top of the sphere: y = {x[centre, 1]}")
    if abs(support - MASS * G) > 0.1 * MASS * G:
        failures.append(f"contact forces {support} N do not carry the weight {MASS * G} N")
    if failures:
        sys.exit("FAILED: " + "\n        ".join(failures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
