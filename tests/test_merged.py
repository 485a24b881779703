"""deltabar of (30) for the merged acrobot of Sect. 2.4 over every frozen posture (paa_mj.theory.merged): its bounds
on boxes hold, a sign change is found where sampling misses it, and a proof of one sign is what it says."""
import numpy as np
import pytest

from paa_mj.model.dynamics import AnalyticModel
from paa_mj.model.params import RobotParams
from paa_mj.theory.merged import Deltabar, merged_acrobot


def chain(l1, n=5):
    """Link 1 of length l1 and n - 1 links sharing 2 m: the folded-back tail reaches the bar's height at l1 = 2."""
    return AnalyticModel.from_params(RobotParams.uniform_rods(np.array([1.0] + [0.5] * (n - 1)),
                                                              np.array([l1] + [2.0 / (n - 1)] * (n - 1))))


@pytest.mark.parametrize("n", [3, 5, 7])
def test_box_bounds_hold_at_sampled_points(n):
    d = Deltabar(chain(1.3, n))
    rng = np.random.default_rng(n)
    for radius in (0.01, 0.3, 1.0, 3.0):
        centres = rng.uniform(-np.pi, np.pi, (60, n - 2))
        radii = radius * rng.uniform(0.2, 1.0, (60, n - 2))
        lower, upper, value, _ = d.box_bounds(centres, radii)
        points = centres[:, None] + radii[:, None] * rng.uniform(-1, 1, (60, 400, n - 2))
        points[:, :2 ** (n - 2)] = centres[:, None] + radii[:, None] * np.array(
            np.meshgrid(*[[-1.0, 1.0]] * (n - 2), indexing="ij")).reshape(n - 2, -1).T  # the corners too
        values = d.values(points.reshape(-1, n - 2)).reshape(60, 400)
        assert np.all(values >= lower[:, None]) and np.all(values <= upper[:, None])
        assert np.allclose(value, d.values(centres))
        if radius == 0.01:  # and they close in on the values as the boxes shrink
            assert np.max(upper - lower) < 0.01 * d.scale


def test_a_narrow_sign_change_that_random_postures_miss_is_found():
    """Link 1 just longer than the folded-back tail: deltabar < 0 only near the fully folded posture."""
    am = chain(2.01)
    samples = Deltabar(am).values(np.random.default_rng(0).uniform(-np.pi, np.pi, (20001, 3)))
    assert samples.min() > 0  # what 20001 random postures saw
    found = merged_acrobot(am)
    assert found.controllable is False and found.minimum < 0 < found.maximum
    assert Deltabar(am).values(np.cumsum(found.argmin)[None])[0] == pytest.approx(found.minimum, rel=1e-12)


def test_one_sign_is_proved_by_the_branch_and_bound():
    am = chain(1.0)
    found = merged_acrobot(am)
    assert found.controllable is True and found.boxes > 0 and "proves" in found.method
    proved = float(found.method.split(">= ")[1].split()[0])
    samples = Deltabar(am).values(np.random.default_rng(1).uniform(-np.pi, np.pi, (200000, 3)))
    assert 0 < proved <= samples.min() and found.minimum <= samples.min()


def test_a_zero_to_rounding_is_no_proof_and_a_budget_of_nothing_decides_nothing():
    exact = merged_acrobot(chain(2.0))  # the folded-back tail ends at the bar's height: deltabar = 0 there
    assert exact.controllable is False and abs(exact.minimum) < 1e-12
    undecided = merged_acrobot(chain(1.0), budget_cpu_s=0.0)
    assert undecided.controllable is None and "undecided" in undecided.method


def test_an_eight_link_chain_is_decided_within_the_budget():
    """The make-model chain of masses 8..1 kg: deltabar >= 46.8 found, its maximum 1744; the proof needs boxes of a
    tenth of a radian near the folded postures in six angles."""
    am = AnalyticModel.from_params(RobotParams.uniform_rods(np.arange(8.0, 0.0, -1.0),
                                                            np.array([0.5, 0.4, 0.4, 0.3, 0.3, 0.3, 0.2, 0.2])))
    found = merged_acrobot(am)
    assert found.controllable is True and found.minimum > 0, found.method
