"""`paa-mj reproduce --quick`: every figure, the report, its verdicts and the two numbers explained."""
import json

import numpy as np
import pytest

from paa_mj.cli import main


FIGURES = ["fig05_f54_table1", "fig06_energy_table1", "fig07_angles_table1", "fig08_torques_table1",
           "fig09_angles_switch_table1", "fig10_torques_switch_table1", "fig11_f54_table2", "fig12_energy_table2",
           "fig13_angles_table2", "fig14_torques_table2", "switch_time_vs_dt", "switch_sensitivity", "basin_table1"]
# The paper's characteristic polynomial at DUU, Table 1, gains (66), highest power first.
PAPER_DUU = [1.0, -0.2265, 16.10, -12.74, -1000.88, -1366.68, -8640.19]


# Smaller still than --quick's studies: the statistics of the report need only be there, with their shape.
# (Two runs per perturbation size and a 2 x 2 basin: 6 + 4 runs of 25-40 s instead of 12 + 16, about 10 CPU-s less.)
SMALL = {"sensitivity_runs": 2, "reading_runs": 2, "reading_sizes": (1e-9,), "reading_cases": 1, "basin_grid": 2,
         "basin_t_final": 25.0}


@pytest.fixture(scope="module")
def reproduction(tmp_path_factory):
    from paa_mj.outputs import reproduce

    out = tmp_path_factory.mktemp("reproduction")
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(reproduce.SIZES, "quick", SMALL)
        assert main(["reproduce", "--out", str(out), "--quick", "--no-video"]) == 0
    return out


@pytest.fixture(scope="module")
def results(reproduction):
    return json.loads((reproduction / "results.json").read_text())


def test_every_figure_is_a_png_and_an_svg(reproduction):
    for name in FIGURES:
        data = (reproduction / "figures" / f"{name}.png").read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, name
        assert "<svg" in (reproduction / "figures" / f"{name}.svg").read_text()[:2000], name


def test_report_marks_each_claim_and_stands_alone(reproduction):
    report = (reproduction / "report.md").read_text()
    table = [line for line in report.splitlines() if line.startswith(("| Table", "| Figs", "| DUU"))]
    assert len(table) >= 20
    assert all(" reproduced" in line.split("|")[-2] or "**not reproduced**" in line for line in table)
    for claim in ("Table 1: kD_min (41)", "Figs. 9-10: LQR balances at UDD", "Figs. 12-14: link 1 never swings up",
                  "Table 2: f = 1 at z = 0, 2 pi, (54) fails (Fig. 11)"):
        row = next(line for line in table if claim in line)
        assert row.rstrip().endswith("| reproduced |"), row
    assert "about 13.38 s" in report  # the paper's switch time stands beside ours
    assert "PAA_MODEL" not in report and "docs/model.md" in report and "Multibody System Dynamics" in report
    assert "a candidate, not a confirmation" in report and "not a graze" in report


def test_duu_both_readings_for_both_robots(results):
    for key in ("duu", "duu_paper_reading"):
        for robot in ("gymnast", "example2"):
            entry = results[key][robot]
            assert len(entry["coefficients"]) == 7 and len(entry["eigenvalues"]) == 6
            assert max(re for re, _ in entry["eigenvalues"]) > 0  # DUU unstable either way
    reading = results["duu_paper_reading"]["gymnast"]["coefficients"]
    np.testing.assert_allclose(reading, PAPER_DUU, rtol=1e-3)  # the paper's polynomial, recomputed
    assert abs(results["duu"]["gymnast"]["coefficients"][1] - PAPER_DUU[1]) > 1  # as written, it is not the paper's


def test_switch_entries_sensitivity_and_candidate(results):
    entries = results["switch_entries"]
    assert len(entries) == 5
    assert entries[0]["t_enter"] == pytest.approx(8.0757, abs=1e-3)
    assert all(set(e) == {"t_enter", "duration", "min_margin", "lqr_balances"} for e in entries)
    assert all(e["min_margin"] < 0 and e["duration"] > 0 for e in entries)
    assert [e["t_enter"] for e in entries] == sorted(e["t_enter"] for e in entries)
    sizes = [row["perturbation"] for row in results["switch_sensitivity"]]
    assert sizes == [1e-9, 1e-6, 1e-3]
    for row in results["switch_sensitivity"]:
        assert set(row) >= {"perturbation", "n", "switched_fraction", "median", "q1", "q3"}
        assert row["q1"] <= row["median"] <= row["q3"]
    candidate = results["switch_candidate_reading"]
    assert candidate["t_switch"] == pytest.approx(13.39, abs=0.05)
    assert candidate["integrators"] and candidate["binding"]


def test_results_json_and_runs(reproduction, results):
    assert results["runs"]["gymnast_switch"]["balanced"] is True
    assert results["runs"]["example2_swingup"]["switch_time"] is None
    engines = {r["engine"] for r in results["discretisation_study"]}
    assert engines == {"mujoco", "analytic"}
    assert results["basin_table1"]["cells"] == SMALL["basin_grid"] ** 2
    assert results["sizes"]["sensitivity_runs"] == SMALL["sensitivity_runs"]  # the sizes the report states
    for run in ("gymnast_swingup", "gymnast_switch", "example2_swingup"):
        assert (reproduction / "runs" / run / "trajectory.npz").exists()


def test_region_visits_count_a_start_inside_and_the_last_partial_interval():
    """A made-up solution with q1 = cos(t) - 0.5 and a region |q1| < 0.6: inside from t = 0 to acos(-0.1), then again
    from 2 pi - acos(-0.1), which falls in the last partial millisecond before the end."""
    from types import SimpleNamespace

    from paa_mj.studies.switching import region_visits

    condition = SimpleNamespace(margin=lambda q, qd, t: np.abs(q[..., 0]) / 0.6 - 1.0)

    def sol(t):
        t = np.asarray(t, float)
        return np.stack([np.cos(t) - 0.5] + [np.zeros_like(t)] * 5)

    second = 2 * np.pi - np.arccos(-0.1)
    t_end = np.floor(second * 1e3) / 1e3 + 0.0009  # between the last whole millisecond and the end
    assert second < t_end
    visits = region_visits(SimpleNamespace(t=np.array([0.0, t_end]), sol=sol), condition)
    assert len(visits) == 2 and visits[0][0] == 0.0  # inside from the start
    assert visits[0][1] == pytest.approx(np.arccos(-0.1), abs=1e-9)
    assert visits[1][0] == pytest.approx(second, abs=1e-9) and visits[1][1] == t_end
