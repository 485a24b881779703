"""Seeds: one range for every ``--seed`` of every command and every ``seed=`` of the studies, the narrowest that a
generator of the package takes (NumPy's legacy RandomState, which RealAIGym's protocols draw from)."""
import argparse
from types import SimpleNamespace

import numpy as np
import pytest

from paa_mj.errors import PaaError
from paa_mj.limits import SEED_LIMIT, SEED_LIMITS, check_seed


def _seed_options():
    """(command, its --seed action) for every command of the parser that has one."""
    from paa_mj.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return [(name, action) for name, parser in sub.choices.items() for action in parser._actions
            if "--seed" in action.option_strings]


def test_the_range_is_the_narrowest_generator_s():
    assert SEED_LIMIT == 2**32 == min(SEED_LIMITS.values())
    np.random.RandomState(SEED_LIMIT - 1)
    np.random.RandomState([SEED_LIMIT - 1, 5, 20, 9])  # robustness-v2's streams
    with pytest.raises(ValueError):
        np.random.RandomState(SEED_LIMIT)  # the limit is the generator's own, not a choice of ours


def test_every_seed_option_takes_the_one_range():
    options = _seed_options()
    assert {"realaigym", "robustness", "compare", "atlas", "roa", "peers", "check"} <= {name for name, _ in options}
    for name, action in options:
        assert action.type(str(SEED_LIMIT - 1)) == SEED_LIMIT - 1 and action.type("0") == 0
        for bad in (str(SEED_LIMIT), "-1", str(2**63)):
            with pytest.raises(argparse.ArgumentTypeError, match=r"\[0, 2\^32\)"):
                action.type(bad)


@pytest.mark.parametrize("command", ["realaigym --protocol global-v3", "robustness", "atlas --simulate", "roa"])
def test_a_seed_past_the_range_is_one_line(run, command):
    result = run(*command.split(), "--seed", str(SEED_LIMIT))
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert "--seed: must be a whole number in [0, 2^32)" in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_the_studies_take_the_same_range():
    from paa_mj.control.registry import ControllerSpec
    from paa_mj.model.robot import load_robot
    from paa_mj.realaigym import study as rg
    from paa_mj.task import Task

    acrobot = load_robot("realaigym_acrobot")
    task = Task.named("stretched", acrobot)
    spec = ControllerSpec("spong", task=task)
    with pytest.raises(PaaError, match=r"--seed must be a whole number in \[0, 2\^32\)"):
        rg.run_protocol("global-v3", acrobot, spec, task, seed=SEED_LIMIT, progress=False)
    # the largest seed draws: a run's streams of robustness-v2 (pulses, normals)
    for case in rg.robustness_cases(acrobot)[-3:]:
        rg._case_inputs(SimpleNamespace(n=2), acrobot, rg.plant(acrobot), case, rg.their_times(0.1), SEED_LIMIT - 1)
    with pytest.raises(PaaError):
        check_seed(True)
    assert check_seed(np.int64(7)) == 7
