# SPDX-License-Identifier: MIT
"""What a Python force callback costs per evaluation: the median time of a step of a small rope
world (symplectic Euler, one callback evaluation per step) with a callback that returns a
preallocated zero array, minus the same without one.

    python bindings/python/bench_callback.py
"""
import time

import numpy as np

import defsim


def step_time(n_vertices: int, callback: bool, steps: int = 20000) -> float:
    with defsim.World("symplectic_euler", gravity=(0, 0, 0)) as w:
        w.add_body(defsim.mesh_rope((0, 0, 0), (1, 0, 0), n_vertices - 1),
                   material=defsim.Material("spring", stiffness=10, vertex_mass=0.1))
        zero = np.zeros((w.vertex_count, 3))
        if callback:
            w.set_force_callback(lambda x, v, t: zero)
        t0 = time.perf_counter()
        w.step(1e-4, steps=steps)
        return (time.perf_counter() - t0) / steps


if __name__ == "__main__":
    for n in (2, 1000):
        base = np.median([step_time(n, False) for _ in range(5)])
        with_cb = np.median([step_time(n, True) for _ in range(5)])
        print(f"{n:5d} vertices: step {base * 1e6:7.2f} us, with a callback {with_cb * 1e6:7.2f} us, "
              f"per evaluation {(with_cb - base) * 1e6:6.2f} us")
