# SPDX-License-Identifier: MIT
"""Options and statistics by name: World(options=...), set_option, option, options, stat, and
the backend's counters in stats(). "testmod" is the test module (tests/unit/testmod.c): symplectic
Euler that divides velocities by 1 + h damping after each step, with one counter, "steps"."""
from __future__ import annotations

import numpy as np
import pytest

import defsim


def test_core_options_by_name(box: defsim.Mesh) -> None:
    with defsim.World(options={"core.simd": "scalar", "core.substep_safety": 0.5}) as w:
        assert w.option("core.simd") == "scalar"
        assert w.option("core.substep_safety") == 0.5
        assert w.option("core.auto_substep") is False
        w.set_option("core.auto_substep", True)
        assert w.option("core.auto_substep") is True
        w.set_option("core.auto_substep", "off")
        assert w.option("core.auto_substep") is False
        w.set_option("core.simd", 2)    # a choice by index
        assert w.option("core.simd") == "generic"
        assert w.options() == {"core.simd": "generic", "core.auto_substep": False,
                               "core.substep_safety": 0.5, "core.watchdog": True,
                               "core.watchdog_energy_growth": 10.0, "core.watchdog_max_stretch": 100.0,
                               "core.contact_dhat": 1e-3, "core.contact_kappa": 0.0,
                               "core.contact_frequency": 0.0, "core.friction_eps_v": 1e-3,
                               "core.body_contact": False}


def test_bad_options_raise_and_change_nothing() -> None:
    with defsim.World() as w:
        bad = [("core.substep_safety", 0.0), ("core.substep_safety", "1.5"),
               ("core.simd", "sse2"), ("core.auto_substep", "maybe"), ("core.nothing", 1),
               ("sundials_ida.rtol", 1e-6), ("rtol", 1e-6), ("core.simd", [1])]
        for name, value in bad:
            with pytest.raises(defsim.InvalidArgumentError):
                w.set_option(name, value)
        assert w.options() == {"core.simd": "auto", "core.auto_substep": False,
                               "core.substep_safety": 0.8, "core.watchdog": True,
                               "core.watchdog_energy_growth": 10.0, "core.watchdog_max_stretch": 100.0,
                               "core.contact_dhat": 1e-3, "core.contact_kappa": 0.0,
                               "core.contact_frequency": 0.0, "core.friction_eps_v": 1e-3,
                               "core.body_contact": False}
        with pytest.raises(defsim.InvalidArgumentError):
            w.option("core.nothing")
        with pytest.raises(defsim.InvalidArgumentError):
            w.stat("nothing")
    with pytest.raises(defsim.InvalidArgumentError):
        defsim.World(options={"core.substep_safety": 2.0})


def test_options_at_creation_in_order() -> None:
    with defsim.World(options={"core.auto_substep": True, "core.substep_safety": 0.25}) as w:
        assert w.option("core.auto_substep") is True
        assert w.option("core.substep_safety") == 0.25


def test_backend_option_and_counter(box: defsim.Mesh) -> None:
    h, damping = 1e-3, 40.0
    with defsim.World("testmod", gravity=(0, 0, 0), options={"testmod.damping": damping}) as w:
        assert w.option("testmod.damping") == damping
        assert set(w.options()) == {"core.simd", "core.auto_substep", "core.substep_safety",
                                    "core.watchdog", "core.watchdog_energy_growth",
                                    "core.watchdog_max_stretch", "core.contact_dhat",
                                    "core.contact_kappa", "core.contact_frequency",
                                    "core.friction_eps_v", "core.body_contact",
                                    "testmod.damping"}
        w.add_body(box)
        v0 = np.zeros((w.vertex_count, 3))
        v0[:, 0] = 1.0
        w.velocities = v0
        w.step(h, steps=3)
        # A uniform translation has no elastic force: v = v0 / (1 + h damping)^3.
        np.testing.assert_allclose(w.velocities[:, 0], (1 + h * damping) ** -3, rtol=1e-9)
        assert w.stat("testmod.steps") == 3.0
        assert w.stats().counters == {"testmod.steps": 3.0}
        # A changed option takes effect at the next step (the backend is re-initialised).
        w.set_option("testmod.damping", "0")
        w.step(h)
        np.testing.assert_allclose(w.velocities[:, 0], (1 + h * damping) ** -3, rtol=1e-9)
        w.reset_stats()
        assert w.stat("testmod.steps") == 0.0 and w.stats().counters["testmod.steps"] == 0.0


def test_stats_by_name_match_stats(box: defsim.Mesh) -> None:
    with defsim.World(num_threads=1) as w:
        w.add_body(box, material=defsim.Material("stvk", mass_damping=0.1))
        w.step(1e-3, steps=5)
        w.stable_step()
        s = w.stats()
        for field in ("steps", "force_evals", "threads", "time_step", "stable_step", "passes",
                      "substeps"):
            assert w.stat(field) == float(getattr(s, field)), field
        assert w.stat("steps") == 5.0
        assert s.stable_step > 0.0 and isinstance(s.stable_step, float)
        assert s.counters == {}
        assert not hasattr(s, "newton_iterations")   # a backend counter now, by name
