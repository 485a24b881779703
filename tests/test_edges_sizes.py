"""Work is sized before it starts, wherever it is sized: memory of the vector environment, time of a long run."""
from __future__ import annotations

import pytest

gym = pytest.importorskip("gymnasium")


def test_a_vector_environment_too_big_for_memory_is_refused_before_it_grows():
    """num_envs = 1e6 (about 400 KB each, 373 GiB) is refused in one line that says what it would need (it was
    accepted and grew past 19.8 GB)."""
    import paa_mj.envs  # noqa: F401 - registers the environments

    with pytest.raises(ValueError, match=r"^would need 373 GiB of memory for 1000000 sub-environments .*lower"
                                         r" num_envs$"):
        gym.make_vec("paa_mj/GymnastKip-v1", num_envs=1_000_000, vectorization_mode="vector_entry_point")


def test_the_estimate_scales_with_the_memory_free(monkeypatch):
    import paa_mj.envs  # noqa: F401
    from paa_mj import limits

    monkeypatch.setattr(limits, "available_memory", lambda: 2 * 8 * limits.ENV_BYTES)  # room for 8
    envs = gym.make_vec("paa_mj/GymnastKip-v1", num_envs=8, vectorization_mode="vector_entry_point")
    envs.close()
    with pytest.raises(ValueError, match="for 9 sub-environments"):
        gym.make_vec("paa_mj/GymnastKip-v1", num_envs=9, vectorization_mode="vector_entry_point")


def test_a_long_run_is_announced_with_its_estimate(capsys):
    """--dt 1e-9 for 1 s (1e9 steps, hours) is accepted under the day's limit but said before it starts, with what
    shortens it (it ran on silently); past the limit it is refused, as before."""
    from paa_mj.errors import PaaError
    from paa_mj.limits import check_steps

    check_steps(1e9, "1 rollout(s) of 1 s at dt = 1e-09 s", "--t-final or raise --dt", cores=1)
    err = capsys.readouterr().err
    assert err.startswith("paa-mj: 1e+09 physics steps for 1 rollout(s) of 1 s at dt = 1e-09 s: about ")
    assert "hours here (an estimate); lower --t-final or raise --dt to shorten it" in err
    check_steps(1e3, "a short run", "--t-final", cores=1)
    assert capsys.readouterr().err == ""
    with pytest.raises(PaaError, match="would need 1e\\+11 physics steps"):
        check_steps(1e11, "a run", "--t-final", cores=1)


def test_the_simulate_command_says_the_estimate_of_a_tiny_time_step(run, monkeypatch):
    """The command's own check (the batch engine's), stopped right after it: nothing is simulated here."""
    from paa_mj.sim import batch

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch, "check_memory", stop)  # the check after the steps' estimate
    result = run("simulate", "--dt", "1e-9", "--t-final", "1")
    assert "1e+09 physics steps for 1 rollout(s) of 1 s at dt = 1e-09 s: about" in result.stderr


def test_the_gym_page_states_the_step_the_code_takes():
    """docs/gym.md: a step is frame_skip physics steps, 10 ms on the gymnast and 5 ms on a 0.5 ms robot."""
    from pathlib import Path

    import paa_mj.envs  # noqa: F401
    from paa_mj.envs.spaces import FRAME_SKIP

    page = (Path(__file__).resolve().parents[1] / "docs" / "gym.md").read_text()
    assert f"({FRAME_SKIP} by default: 10 ms at the gymnast's 1 ms step, 5 ms for a robot of 0.5 ms" in page
    env = gym.make("paa_mj/GymnastKip-v1")
    assert env.unwrapped.dt == pytest.approx(FRAME_SKIP * 1e-3)
    env.close()
