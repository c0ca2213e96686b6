# SPDX-License-Identifier: MIT
"""Throwing a cloth onto a target by optimising the pin-target controls (docs/gradients.md).

A 0.6 m square spring cloth lies flat at 1 m, held at two corners by driven pins. For the
first THROW steps the host moves the two pins (their targets, one per step and pin: the
controls); then it lets go and the cloth flies free. The goal: at the time of the loss, before
the cloth reaches the ground, every vertex should be where the flat cloth would be if it had
been carried 1.2 m forward and 0.4 m down (the target: a flat landing over a spot). The loss is
the mean squared distance of the vertices to their targets then, plus a small penalty on the
pins' accelerations (a smooth throw). Its gradient with respect to all the targets comes from
two recordings, the throw (driven pins, `pin_targets`) and the flight in a world without the
pins (`initial_positions`, `initial_velocities`, chained into the throw's last state), each run
backward once; L-BFGS with a backtracking line search takes the steps.

Writes the loss per iteration (CSV) and its plot (PNG, matplotlib). Checks before exiting 0:
the loss falls by at least DROP within the iterations given, and the cloth's centre at the
loss time is within 5 cm of the target's.

    python throw_cloth.py [--quick] [--iterations N] [--out DIR]
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import numpy as np

import defsim

H = 1.0 / 120.0           # s
THROW, FLIGHT = 24, 36    # steps with the pins driven, then free
SIZE, HEIGHT = 0.6, 1.0   # m
SHIFT = np.array([1.2, -0.4, 0.0])   # where the flat cloth should be at the loss time
SHAPE = 0.2               # weight of the shape's mismatch against the centre's
SMOOTH = 0.01             # weight of the pins' accelerations (m^2 per (m/step^2)^2)
DROP = 50.0               # the loss must fall by this factor


def make_world(cloth: defsim.Mesh) -> defsim.World:
    w = defsim.World("newton_cholmod", gravity=(0, -9.81, 0), num_threads=1,
                     options={"newton_cholmod.tolerance": 1e-6,
                              "newton_cholmod.max_iterations": 200,
                              "newton_cholmod.projection": "clamp"})
    w.add_body(cloth, material=defsim.Material(
        "spring", stiffness=200.0, vertex_mass=0.1 / cloth.vertex_count, mass_damping=0.1),
        shear_stiffness=50.0, bend_stiffness=0.5)
    return w


def mismatch(x: np.ndarray, target: np.ndarray):
    """|c - c*|^2 + SHAPE mean_i |(x_i - c) - (t_i - c*)|^2 (c: the centre): the cloth over the
    spot, and flat as the target is; and its gradient with respect to x."""
    n = len(x)
    d = x.mean(axis=0) - target.mean(axis=0)
    r = (x - x.mean(axis=0)) - (target - target.mean(axis=0))
    L = float(d @ d) + SHAPE * float(np.mean(np.sum(r ** 2, axis=1)))
    # r sums to zero over the vertices, so the centre's part of its gradient vanishes
    return L, 2.0 * d / n + SHAPE * 2.0 * r / n


def run(cloth: defsim.Mesh, handles: np.ndarray, P: np.ndarray, grad: bool):
    """The throw with pin targets P (THROW, 2, 3) and the flight: the loss's mismatch term and,
    with grad, its gradient with respect to P."""
    w = make_world(cloth)
    body = w.bodies[0]
    body.pin(handles)
    target = cloth.positions + SHIFT
    n = w.vertex_count
    throw = w.record(interval=1) if grad else None
    for s in range(THROW):
        body.set_pin_targets(handles, P[s])
        w.step(H)
    # A recording follows one set of pins: the flight, without them, runs in a world of its own
    # from the throw's last state (the released corners keep their velocity).
    f = make_world(cloth)
    f.set_state(w.positions, w.velocities)
    flight = f.record(interval=1) if grad else None
    f.step(H, FLIGHT)
    x = f.positions
    L, dL = mismatch(x, target)
    if not grad:
        return L, None, x
    dL_dx = np.zeros((FLIGHT + 1, n, 3))
    dL_dx[-1] = dL
    g2 = flight.backward(dL_dx=dL_dx, params=["initial_positions", "initial_velocities"])
    # the flight's start is the throw's end: its adjoints are the throw's loss gradient there
    dx = np.zeros((THROW + 1, n, 3))
    dv = np.zeros((THROW + 1, n, 3))
    dx[-1] = g2["initial_positions"]
    dv[-1] = g2["initial_velocities"]
    g1 = throw.backward(dL_dx=dx, dL_dv=dv, params=["pin_targets"])
    return L, g1["pin_targets"][:, handles], x


def smoothness(P: np.ndarray, start: np.ndarray):
    """SMOOTH * sum of |p_{s+1} - 2 p_s + p_{s-1}|^2 over the pins (p_{-1} = p_{-2} = start: they
    start at rest) and its gradient."""
    Q = np.concatenate([start[None], start[None], P])
    a = Q[2:] - 2 * Q[1:-1] + Q[:-2]
    G = np.zeros_like(Q)
    G[2:] += 2 * a
    G[1:-1] -= 4 * a
    G[:-2] += 2 * a
    return SMOOTH * float(np.sum(a ** 2)), SMOOTH * G[2:]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="a coarser cloth (for the test)")
    ap.add_argument("--iterations", type=int, default=30, help="L-BFGS iterations (at most)")
    ap.add_argument("--out", default="throw_cloth_out", help="output folder")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    n = 6 if args.quick else 12
    cloth = defsim.mesh_cloth((-SIZE / 2, HEIGHT, -SIZE / 2), (SIZE, 0, 0), (0, 0, SIZE), n, n)
    # the two corners at x = -SIZE/2 (the back edge, vertex index j (n + 1) + i): the hands
    handles = np.array([0, n * (n + 1)])
    start = cloth.positions[handles]
    P = np.repeat(start[None], THROW, axis=0)      # first guess: held still, then let go

    def total(P: np.ndarray, grad: bool):
        L, g, x = run(cloth, handles, P, grad)
        R, gR = smoothness(P, start)
        return L + R, (g + gR if grad else None), L, R, x

    # L-BFGS (memory 8) with a backtracking (Armijo) line search: each iteration one run with
    # the gradient (two recordings, two backward passes) and the line search's plain runs.
    history = []
    t0 = time.perf_counter()
    f, g, L, R, x = total(P, True)
    S, Y = [], []
    runs = 1
    for it in range(args.iterations + 1):
        history.append((it, f, L, R, x.mean(axis=0)))
        c = x.mean(axis=0)
        print(f"iteration {it:3d}: loss {f:.6e} (mismatch {L:.6e}, smoothness {R:.3e}), "
              f"centre at t = {(THROW + FLIGHT) * H:.2f} s: ({c[0]:.3f}, {c[1]:.3f}, "
              f"{c[2]:.3f}) m")
        if it == args.iterations:
            break
        # the two-loop recursion: d = -H g
        q = g.ravel().copy()
        alphas = []
        for s_, y_ in reversed(list(zip(S, Y))):
            a = (s_ @ q) / (y_ @ s_)
            alphas.append(a)
            q -= a * y_
        if S:
            q *= (S[-1] @ Y[-1]) / (Y[-1] @ Y[-1])
        else:
            q *= 0.05 / max(np.abs(q).max(), 1e-300)   # the first step moves a target by 5 cm
        for (s_, y_), a in zip(zip(S, Y), reversed(alphas)):
            q += s_ * (a - (y_ @ q) / (y_ @ s_))
        d = -q.reshape(P.shape)
        slope = float(np.sum(g * d))
        if slope >= 0.0:   # not a descent direction: start the memory again
            S, Y = [], []
            d = -g * 0.05 / max(np.abs(g).max(), 1e-300)
            slope = float(np.sum(g * d))
        step = 1.0
        while True:
            Pn = P + step * d
            try:
                fn = total(Pn, False)[0]
            except defsim.NotConvergedError:
                fn = np.inf
            runs += 1
            if fn <= f + 1e-4 * step * slope or step < 1e-4:
                break
            step *= 0.5
        if not fn < f:   # no decrease along the direction: as far as it goes
            print(f"iteration {it + 1}: the line search found no decrease; stopping")
            break
        fn, gn, L, R, x = total(Pn, True)
        runs += 1
        sv, yv = (Pn - P).ravel(), (gn - g).ravel()
        if sv @ yv > 1e-12 * np.linalg.norm(sv) * np.linalg.norm(yv):
            S.append(sv)
            Y.append(yv)
            S, Y = S[-8:], Y[-8:]
        P, f, g = Pn, fn, gn
    seconds = time.perf_counter() - t0

    with open(os.path.join(args.out, "loss.csv"), "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["iteration", "loss", "mismatch_m2", "smoothness", "cx_m", "cy_m", "cz_m"])
        for it, tot, L, R, c in history:
            wr.writerow([it, f"{tot:.9e}", f"{L:.9e}", f"{R:.9e}", *(f"{q:.6f}" for q in c)])
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    its = [h[0] for h in history]
    ax[0].semilogy(its, [h[1] for h in history], "o-", ms=3, label="loss")
    ax[0].semilogy(its, [h[2] for h in history], "--", label="mismatch (m$^2$)")
    ax[0].set_xlabel("L-BFGS iteration")
    ax[0].set_ylabel("loss")
    ax[0].set_title("Throwing a cloth: loss")
    ax[0].legend()
    ax[0].grid(True, which="both", alpha=0.3)
    # the optimised throw: the pins' paths and the cloth at the loss time, side view (x, y)
    first = run(cloth, handles, np.repeat(start[None], THROW, axis=0), grad=False)[2]
    ax[1].plot(P[:, 0, 0], P[:, 0, 1], "r.-", label="pin targets (optimised)")
    ax[1].plot(first[:, 0], first[:, 1], "x", color="0.6", ms=4, label="cloth, first guess")
    ax[1].plot(x[:, 0], x[:, 1], "b.", ms=4, label="cloth, optimised")
    tgt = cloth.positions + SHIFT
    ax[1].plot(tgt[:, 0], tgt[:, 1], "g_", ms=8, label="target")
    ax[1].set_xlabel("x (m)")
    ax[1].set_ylabel("y (m)")
    ax[1].set_title(f"side view at t = {(THROW + FLIGHT) * H:.2f} s")
    ax[1].axis("equal")
    ax[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "loss.png"), dpi=100)

    L0, Lend = history[0][1], history[-1][1]
    centre_err = float(np.linalg.norm(x.mean(axis=0) - (cloth.positions + SHIFT).mean(axis=0)))
    print(f"loss {L0:.6e} -> {Lend:.6e} (down {L0 / Lend:.1f}x) in {len(history) - 1} "
          f"iterations ({runs} runs: {len(history)} with two recordings and two backward "
          f"passes), "
          f"{seconds:.1f} s; the centre {100 * centre_err:.2f} cm from the target's")
    ok = L0 / Lend >= DROP and centre_err <= 0.05
    if not ok:
        print(f"FAILED: the loss must fall by {DROP}x and the centre come within 5 cm",
              file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
