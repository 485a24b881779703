"""Results that cost more than a second are kept by content (:func:`paa_mj.provenance.kept`), as kD_min is."""
from __future__ import annotations

import math

import numpy as np
import pytest

from paa_mj.provenance import kept


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_kept_computes_once_per_content(cache):
    calls = []

    def compute():
        calls.append(1)
        return {"rho": math.inf, "x": [0.1, 1 / 3], "nan": math.nan}

    first = kept("thing", compute, a=np.arange(3.0), b="x")
    again = kept("thing", compute, a=np.arange(3.0), b="x")
    assert len(calls) == 1 and again["x"] == first["x"] and again["rho"] == math.inf and math.isnan(again["nan"])
    kept("thing", compute, a=np.arange(3.0) + 1e-15, b="x")  # other content: computed again
    assert len(calls) == 2
    for path in (cache / "thing").iterdir():  # an unreadable kept file is computed again, not an error
        path.write_text("{truncated")
    kept("thing", compute, a=np.arange(3.0), b="x")
    assert len(calls) == 3


def test_a_switch_level_is_kept_across_processes(cache, gymnast, monkeypatch):
    """vc-roa's hand-over level (42 CPU-s by simulation) is computed once: a later process (the memory cache
    emptied here) reads it back, the same S and rho to the bit."""
    from paa_mj.task import Task
    from paa_mj.theory import roa

    calls = []

    def simulated(*args, **kwargs):
        calls.append(1)
        return {"rho": 0.123456789}

    monkeypatch.setattr(roa, "simulated_level", simulated)
    monkeypatch.setattr(roa, "_SWITCH_LEVELS", {})
    task = Task.named("folded", gymnast.analytic)
    Q, R = np.eye(6) * 1e4, np.eye(2)
    S1, rho1 = roa.switch_level(gymnast.analytic, task, Q, R, u_max=[100.0, 100.0], dt=1e-3, method="sampling")
    monkeypatch.setattr(roa, "_SWITCH_LEVELS", {})
    S2, rho2 = roa.switch_level(gymnast.analytic, task, Q, R, u_max=[100.0, 100.0], dt=1e-3, method="sampling")
    assert calls == [1] and rho2 == rho1 == 0.123456789 and np.array_equal(S1, S2)
    roa.switch_level(gymnast.analytic, task, Q, R, u_max=[50.0, 100.0], dt=1e-3, method="sampling")
    assert calls == [1, 1]  # other limits, another level


def test_a_region_of_attraction_reads_back_as_computed(cache, gymnast, monkeypatch):
    from paa_mj.task import Task
    from paa_mj.theory import roa
    from paa_mj.theory.linear import lqr_solution

    monkeypatch.setattr(roa, "simulated_level", lambda *a, **k: {"rho": 0.5, "at_top": False, "samples": 3,
                                                                  "seed": 0, "horizon": 2.0})
    task = Task.named("folded", gymnast.analytic)
    Q, R = np.eye(6) * 1e4, np.eye(2)
    K, S = lqr_solution(gymnast.analytic, task, Q, R)
    args = dict(u_max=None, dt=1e-3, method="sampling", samples=3, box_samples=100, vdot_samples=100)
    first = roa.region_of_attraction(gymnast.analytic, task, K, S, Q, R, **args)
    monkeypatch.setattr(roa, "_region_of_attraction", lambda *a, **k: pytest.fail("computed again"))
    again = roa.region_of_attraction(gymnast.analytic, task, K, S, Q, R, **args)
    assert again.to_dict() == first.to_dict()
