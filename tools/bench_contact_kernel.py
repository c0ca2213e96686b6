# SPDX-License-Identifier: MIT
"""IPC Toolkit's side of the per-contact kernel benchmark (tools/bench_contact_kernel.c).

hessian: a cloth of n x n cells 1/3 of dhat above a jittered, rotated triangle mesh (the cloth's
    heights jittered by +-dhat/4 so that contacts fall in every region), IPC Toolkit's collision
    set of it (vertex-vertex, edge-vertex, edge-edge, face-vertex), written for
    defsim-bench-contact-kernel, and IPC Toolkit's barrier Hessian with and without its PSD
    projection over the whole set timed on one thread (median of rounds).
ccd: random and near-contact point-triangle and edge-edge motions with IPC Toolkit's additive
    CCD time of impact (conservative_rescaling 0.9, min_distance 0), written for the same tool.

File formats (little-endian): hessian: int32 count, double dhat, then per contact int32 type
(0 VV, 1 EV, 2 FV, 3 EE as in src/contact_pair.h), double eps_x (the edge-edge mollifier's
threshold, 0 otherwise), double x[12] (vertices in IPC Toolkit's stencil order, unused ones 0).
ccd: int32 count, then per pair int32 kind (0 point-triangle, 1 edge-edge), double x[12],
double dx[12], double toi (IPC Toolkit's, tmax = 1 when it reports no collision).

Run with IPC Toolkit's Python bindings (pip install ipctk==1.6.1):
    python3 tools/bench_contact_kernel.py hessian --cells 24 --out /tmp/contacts.bin
    python3 tools/bench_contact_kernel.py ccd --pairs 4000 --out /tmp/ccd.bin
"""
import argparse
import statistics
import struct
import time

import ipctk
import numpy as np


def grid(n, size):
    """Vertices and triangles of an n x n cell grid on [0, size]^2 (z = 0)."""
    xs = np.linspace(0.0, size, n + 1)
    v = np.array([[x, y, 0.0] for y in xs for x in xs])
    f = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            f.append([a, a + 1, a + n + 2])
            f.append([a, a + n + 2, a + n + 1])
    return v, np.array(f, dtype=np.int32)


def scene(cells, seed):
    rng = np.random.default_rng(seed)
    size = 1.0
    dhat = size / cells / 4.0
    cv, cf = grid(cells, size)
    cv[:, 2] = dhat / 3.0 + rng.uniform(-dhat / 4.0, dhat / 4.0, len(cv))
    gn = max(2, int(cells * 0.7))
    gv, gf = grid(gn, 1.4 * size)
    gv[:, :2] -= 0.2 * size
    gv[:, :2] += rng.uniform(-0.2, 0.2, (len(gv), 2)) * (1.4 * size / gn)
    c, s = np.cos(0.3), np.sin(0.3)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    gv = (gv - [0.5, 0.5, 0]) @ rot.T + [0.5, 0.5, 0]
    v = np.vstack([cv, gv])
    f = np.vstack([cf, gf + len(cv)])
    return v, f, dhat


def write_contacts(path, collisions, mesh, v, dhat):
    edges, faces = mesh.edges, mesh.faces
    rows = []
    for kind, group in ((0, collisions.vv_collisions), (1, collisions.ev_collisions),
                        (2, collisions.fv_collisions), (3, collisions.ee_collisions)):
        for col in group:
            ids = [i for i in col.vertex_ids(edges, faces) if i >= 0]
            x = np.zeros(12)
            x[: 3 * len(ids)] = v[ids].ravel()
            eps = float(col.eps_x) if kind == 3 else 0.0
            rows.append((kind, eps, x))
    with open(path, "wb") as fh:
        fh.write(struct.pack("<id", len(rows), dhat))
        for kind, eps, x in rows:
            fh.write(struct.pack("<id", kind, eps))
            fh.write(struct.pack("<12d", *x))
    return rows


def time_median(fn, rounds):
    ts = []
    for _ in range(rounds):
        t0 = time.process_time()
        fn()
        ts.append(time.process_time() - t0)
    return statistics.median(ts)


def hessian(args):
    ipctk.set_num_threads(1)
    v, f, dhat = scene(args.cells, args.seed)
    edges = ipctk.edges(f)
    mesh = ipctk.CollisionMesh(v, edges, f)
    collisions = ipctk.NormalCollisions()
    collisions.build(mesh, v, dhat)
    rows = write_contacts(args.out, collisions, mesh, v, dhat)
    counts = [sum(1 for r in rows if r[0] == k) for k in range(4)]
    pot = ipctk.BarrierPotential(dhat, 1.0)
    clamp = ipctk.PSDProjectionMethod.CLAMP
    none = ipctk.PSDProjectionMethod.NONE
    tc = time_median(lambda: pot.hessian(collisions, mesh, v, clamp), args.rounds)
    tn = time_median(lambda: pot.hessian(collisions, mesh, v, none), args.rounds)
    # per collision through the bindings, less the bindings' overhead (a call that does no
    # geometry on the same objects)
    groups = [collisions.vv_collisions, collisions.ev_collisions, collisions.fv_collisions,
              collisions.ee_collisions]
    stencils = [(col, col.dof(v, mesh.edges, mesh.faces).ravel()) for g in groups for col in g]

    def each(method):
        for col, x in stencils:
            pot.hessian(col, x, method)

    def overhead():
        for col, x in stencils:
            col.num_vertices()
            x.copy()

    te = time_median(lambda: each(clamp), args.rounds)
    to = time_median(overhead, args.rounds)
    n = len(rows)
    print(f"ipctk per-collision Python calls with CLAMP: {1e9 * te / n:.0f} ns/contact, "
          f"less the call overhead ({1e9 * to / n:.0f} ns): {1e9 * (te - to) / n:.0f} ns/contact")
    print(f"cloth {args.cells}x{args.cells} cells, dhat {dhat:.4g}: {n} contacts "
          f"(VV {counts[0]}, EV {counts[1]}, FV {counts[2]}, EE {counts[3]}) -> {args.out}")
    print(f"ipctk {ipctk.__version__} whole-set Hessian, 1 thread, CPU time, "
          f"median of {args.rounds}: "
          f"with CLAMP {1e3 * tc:.3f} ms = {1e9 * tc / n:.0f} ns/contact; "
          f"without projection {1e3 * tn:.3f} ms = {1e9 * tn / n:.0f} ns/contact")


def ccd(args):
    rng = np.random.default_rng(args.seed)
    narrow = ipctk.AdditiveCCD()
    out = []
    for k in range(args.pairs):
        kind = k & 1
        x = rng.uniform(-1.0, 1.0, 12)
        if k % 4 >= 2:
            # near contact: the pair 1e-3 to 1e-1 of its size apart, moving towards each
            # other by up to twice that distance plus a sliding motion
            x *= 0.5
            if kind == 0:
                x[2] = 0.0
                x[5] = x[8] = x[11] = 0.0
                x[2] = rng.uniform(1e-3, 1e-1)
            else:
                x[2] = x[5] = rng.uniform(1e-3, 1e-1)
                x[8] = x[11] = 0.0
            d = rng.uniform(-1.0, 1.0, 12) * 0.3
            d[2] -= rng.uniform(0.0, 0.2)
            if kind == 1:
                d[5] = d[2]
        else:
            d = rng.uniform(-1.0, 1.0, 12) * 3.0
        p0 = [x[3 * i:3 * i + 3] for i in range(4)]
        p1 = [x[3 * i:3 * i + 3] + d[3 * i:3 * i + 3] for i in range(4)]
        if kind == 0:
            hit, toi = narrow.point_triangle_ccd(*p0, *p1, 0.0, 1.0)
        else:
            hit, toi = narrow.edge_edge_ccd(*p0, *p1, 0.0, 1.0)
        out.append((kind, x, d, toi if hit else 1.0))
    with open(args.out, "wb") as fh:
        fh.write(struct.pack("<i", len(out)))
        for kind, x, d, toi in out:
            fh.write(struct.pack("<i", kind))
            fh.write(struct.pack("<12d", *x))
            fh.write(struct.pack("<12d", *d))
            fh.write(struct.pack("<d", toi))
    hits = sum(1 for o in out if o[3] < 1.0)
    print(f"{len(out)} pairs ({hits} with ipctk toi < 1), conservative_rescaling "
          f"{narrow.conservative_rescaling} -> {args.out}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    h = sub.add_parser("hessian")
    h.add_argument("--cells", type=int, default=24)
    h.add_argument("--seed", type=int, default=1)
    h.add_argument("--rounds", type=int, default=21)
    h.add_argument("--out", default="contacts.bin")
    c = sub.add_parser("ccd")
    c.add_argument("--pairs", type=int, default=4000)
    c.add_argument("--seed", type=int, default=2)
    c.add_argument("--out", default="ccd.bin")
    args = ap.parse_args()
    (hessian if args.cmd == "hessian" else ccd)(args)


if __name__ == "__main__":
    main()
