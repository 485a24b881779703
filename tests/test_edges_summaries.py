"""Every summary states its task: ``goal``, ``task`` and ``success_definition`` (a protocol's own rule where it has
one)."""
import json

import pytest

STATED = ("goal", "task", "success_definition")


@pytest.mark.parametrize("protocol", ["performance-v2", "global-v3"])
def test_realaigym_states_its_task_and_the_protocol_s_success(run, protocol):
    result = run("realaigym", "--protocol", protocol, "--controller", "spong", "--json")
    summary = json.loads(result.stdout)
    assert all(key in summary for key in STATED) and summary["task"]["goal"] == "stretched"
    assert "their" in summary["success_definition"] or "none" in summary["success_definition"]
    if protocol == "performance-v2":
        assert summary["success"] is summary["result"]["criteria"]["success"]
    assert "exerted no torque" not in result.stderr  # spong swings up from rest


def test_the_theory_and_the_gain_search_state_their_tasks(run, monkeypatch):
    summary = json.loads(run("theory", "--json").stdout)
    assert summary["goal"] == "folded" and all(key in summary for key in STATED)
    from paa_mj.studies import gain_search as gs

    small = gs.gain_search
    monkeypatch.setattr(gs, "gain_search", lambda t_final, progress: small(
        robots=(("acrobot", "stretched"), ("gymnast", "folded")), grid=((1.05,), (1.0,), (1.0,)), t_final=t_final,
        progress=progress))
    summary = json.loads(run("gain-search", "--t-final", "0.05", "--json").stdout)
    assert set(summary["success_definition"]) == set(summary["task"]) == {"acrobot stretched", "gymnast folded"}
    assert summary["task"]["gymnast folded"]["goal"] == "folded"
