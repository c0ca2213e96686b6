#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Writes the shell meshes of tests/shells (docs/shells.md), all in metres:

- skirt_panel.obj: one flat gore of a four-gore conical (A-line) skirt, the sector of an annulus
  (waist radius 0.25 m, hem radius 0.75 m, 45 degrees) in the plane z = 0, 6 rings by 12
  segments, each quad split along alternating diagonals;
- skirt_gore.obj: the same panel sewn into its place on the skirt: rolled onto the cone of
  half-angle 30 degrees (four 45-degree gores close the cone, sin 30 = 4 * 45 / 360), apex at
  the origin, hanging along -y: the point at distance rho and angle phi of the flat sector goes to
  rho (sin b cos 2 phi, -cos b, sin b sin 2 phi). Its hinges have non-zero rest angles;
- cusick_N.obj (N = 15, 20, 25): a circular sheet of radius 0.15 m (the 30 cm specimen of the Cusick
  drape test) in the plane y = 0, N rings of 6 k vertices at radius 0.15 k / N, so that ring 3 N / 5
  lies on the 18 cm support disc's edge; between rings k - 1 and k, 6 (2 k - 1) triangles.

and the scene tests/scenes/cusick_drape.json: cusick_25.obj in the fabric "cotton_polyester",
clamped on the disc (its vertices within 9 cm pinned), released flat and damped to rest as
tests/unit/test_shell_drape.c does it (without its static finish).

Run from the repository root: python3 tests/shells/make_meshes.py
"""
import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def write(name, verts, tris, comment):
    with open(os.path.join(HERE, name), "w") as f:
        f.write("# " + comment + " (tests/shells/make_meshes.py)\n")
        for v in verts:
            f.write("v %.9g %.9g %.9g\n" % v)
        for t in tris:
            f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))


def panel(nr=6, na=12, r0=0.25, r1=0.75, span=math.pi / 4):
    polar = [(r0 + (r1 - r0) * i / nr, span * j / na) for i in range(nr + 1) for j in range(na + 1)]
    tris = []
    for i in range(nr):
        for j in range(na):
            a, b = i * (na + 1) + j, i * (na + 1) + j + 1
            c, d = a + na + 1, b + na + 1
            if (i + j) % 2 == 0:
                tris += [(a, b, d), (a, d, c)]
            else:
                tris += [(a, b, c), (b, d, c)]
    return polar, tris


def disc(n, radius=0.15):
    verts = [(0.0, 0.0, 0.0)]
    first = [0]
    for k in range(1, n + 1):
        first.append(len(verts))
        r = radius * k / n
        for j in range(6 * k):
            a = 2 * math.pi * j / (6 * k)
            verts.append((r * math.cos(a), 0.0, r * math.sin(a)))
    tris = []
    for k in range(1, n + 1):
        def outer(s, i):
            return first[k] + (s * k + i) % (6 * k)

        def inner(s, i):
            return 0 if k == 1 else first[k - 1] + (s * (k - 1) + i) % (6 * (k - 1))
        for s in range(6):
            for i in range(k):
                tris.append((outer(s, i + 1), outer(s, i), inner(s, i)))
            for i in range(k - 1):
                tris.append((outer(s, i + 1), inner(s, i), inner(s, i + 1)))
    return verts, tris


def main():
    polar, tris = panel()
    write("skirt_panel.obj", [(r * math.cos(p), r * math.sin(p), 0.0) for r, p in polar], tris,
          "a flat gore of a four-gore A-line skirt: annulus sector 0.25 - 0.75 m, 45 degrees")
    b = math.pi / 6
    write("skirt_gore.obj",
          [(r * math.sin(b) * math.cos(2 * p), -r * math.cos(b), r * math.sin(b) * math.sin(2 * p))
           for r, p in polar], tris,
          "the gore of skirt_panel.obj on its 30-degree cone (developable: rest angles, no stretch)")
    for n in (15, 20, 25):
        v, t = disc(n)
        write("cusick_%d.obj" % n, v, t,
              "the Cusick drape test's 30 cm specimen, %d rings (ring %d on the 18 cm disc)"
              % (n, 3 * n // 5))


    n = 25
    clamp = [i for i in range(1 + 3 * (3 * n // 5) * (3 * n // 5 + 1))]
    scene = {
        "description": "The Cusick drape test (issue 26, docs/shells.md 'Cusick drape'): a 30 cm "
                       "specimen of the measured fabric cotton_polyester (0.22 kg/m^2, 4 kN/m, "
                       "D = 31 uN m) clamped on the 18 cm disc, released flat and damped to rest "
                       "(h = 0.01 s, mass damping 10/s), folds into 6 nodes with a drape "
                       "coefficient of 0.79 as long_shell_drape measures it. The mesh is "
                       "tests/shells/cusick_25.obj (25 rings; its 721 vertices on and within "
                       "the disc's edge are pinned); the box below stands for the pedestal's "
                       "column and touches nothing.",
        "world": {"backend": "newton_cholmod", "h": 0.01, "fps": 20, "duration": 1.4,
                  "options": {"newton_cholmod.tolerance": 1e-7,
                              "newton_cholmod.projection": "auto",
                              "newton_cholmod.max_iterations": 100}},
        "bodies": [{
            "name": "specimen",
            "mesh": {"type": "file", "path": "../shells/cusick_%d.obj" % n},
            "material": {"model": "spring", "mass_damping": 10.0},
            "shell": {"fabric": "cotton_polyester"},
            "pin": clamp,
            "color": [0.8, 0.35, 0.25],
        }],
        "colliders": [{"shape": "box", "position": [0, -0.07, 0],
                       "half_extents": [0.02, 0.06, 0.02]}],
        "output": {"camera": {"azimuth": 30, "elevation": 25, "zoom": 1.0,
                              "fit": [[-0.16, -0.09, -0.16], [0.16, 0.01, 0.16]]}},
    }
    with open(os.path.join(HERE, "..", "scenes", "cusick_drape.json"), "w") as f:
        json.dump(scene, f, indent=2)
        f.write("\n")


if __name__ == "__main__":
    main()
