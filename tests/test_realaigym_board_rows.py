"""The quick form of the RealAIGym boards (docs/realaigym.md, recomputed whole by ``pytest -m claims``): each board's
``mpc`` row states the performance v2 run that this test redoes (success, swing-up time, RealAI score v2)."""
import pytest

from .claims import robot, stated, task

BOARDS = {"realaigym_board_acrobot": ("realaigym_acrobot", "stretched"),
          "realaigym_board_pendubot": ("realaigym_pendubot", "stretched"),
          "realaigym_board_gymnast": ("gymnast", "folded"),
          "realaigym_board_chain4": ("chain4", "stretched")}
#: The boards with the robot-scaled score v2 beside theirs (column 4).
SCALED = ("realaigym_board_gymnast", "realaigym_board_chain4")


def stated_row(claim_name, controller):
    """The cells of ``controller``'s row in the board that the pages state under ``claim_name``."""
    for _, name, text in stated():
        if name == claim_name:
            for line in text.splitlines():
                cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
                if cells[0] == controller:
                    return cells
    raise AssertionError(f"no {controller} row in the board {claim_name}")


@pytest.mark.parametrize("claim_name", sorted(BOARDS))
def test_the_mpc_row_of_each_board_is_what_its_performance_run_gives(claim_name):
    from paa_mj.control.registry import ControllerSpec
    from paa_mj.realaigym.study import run_protocol

    robot_name, goal = BOARDS[claim_name]
    t = task(robot_name, goal)
    summary, _ = run_protocol("performance-v2", robot(robot_name), ControllerSpec("mpc", task=t), t)
    result = summary["result"]
    criteria = result["criteria"]
    made = [str(int(criteria["success"])), f"{criteria['swingup_time']:.2f}", f"{result['score']:.3f}"]
    row = stated_row(claim_name, "mpc")
    assert row[1:4] == made
    if claim_name in SCALED:
        assert row[4] == f"{result['score_robot_scaled']:.3f}"
