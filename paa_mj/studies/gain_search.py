"""The search behind the family rule's gains (:data:`~paa_mj.control.gains.FAMILY_RULE`).

Every robot of :data:`ROBOTS` kips from its task's start ((65); the stretched goal's start is a little off
hanging) at both goals under ``vcl`` ((40), then the LQR (67) on (68)) with the gains of each rule
:class:`~paa_mj.control.gains.GainRule` (margin, p, v) of a grid: kD = margin kD_min (41) of the goal, kP = p kD,
kV = v kD, in MuJoCo (RK4, 1 ms) for ``t_final`` seconds. A rule scores the robots and goals it balances; the
family rule is the rule of the most, ties to the smaller margin.

One start per robot and goal: a kip from a chaotic swing is decided by its details, so a rule that balances one
start may miss its neighbours; the table also shows which robots no rule of the grid balances from their start
(Table 2's robot, whose LQR sampled at 1 ms is unstable, among them).
"""
from __future__ import annotations

import itertools

import numpy as np

from ..control.gains import GainRule, family_gains
from ..control.registry import ControllerSpec
from ..model.robot import load_robot
from ..sim.batch import simulate_batch
from ..task import Task

#: The robots and goals searched over.
ROBOTS = (("gymnast", "folded"), ("gymnast", "stretched"), ("acrobot", "folded"), ("acrobot", "stretched"),
          ("example2", "folded"), ("example2", "stretched"), ("chain4", "folded"), ("chain4", "stretched"),
          ("realaigym_acrobot", "stretched"))
#: The grid of rules: margins on kD_min, then kP / kD and kV / kD.
GRID = ((1.05, 1.5, 2.0, 3.0), (0.25, 0.5, 1.0, 2.0, 4.0), (0.1, 0.25, 0.5, 1.0, 2.0))


def gain_search(robots=ROBOTS, grid=GRID, t_final=30.0, progress=False) -> dict:
    """Which rules of ``grid`` succeed on which robots (the task's success from its start): ``{"rules": [...],
    "robots": [...], "success": (R, B) bool}`` (rules by rows), ``"ranked"``, the rules' indices from the best (the
    most successes, then the smaller margin),
    and ``"best"``, the first of them; ``"tasks"``: the Task of each robot and goal ("NAME GOAL")."""
    rules = [GainRule(*values) for values in itertools.product(*grid)]
    success = np.zeros((len(rules), len(robots)), bool)
    tasks = {}
    for j, (name, goal) in enumerate(robots):
        robot = load_robot(name)
        task = tasks[f"{name} {goal}"] = Task.named(goal, robot)
        specs = [ControllerSpec("vcl", tuple(family_gains(robot.analytic, task, rule).values()), check=False,
                                task=task) for rule in rules]
        result = simulate_batch(robot, np.repeat(task.start[None], len(rules), 0), t_final, task=task,
                                controller=specs, progress=progress)
        success[:, j] = result.success
    score = success.sum(axis=1)
    ranked = sorted(range(len(rules)), key=lambda i: (-score[i], rules[i].margin, i))
    return {"rules": rules, "robots": list(robots), "success": success, "ranked": ranked, "best": rules[ranked[0]],
            "t_final": t_final, "tasks": tasks}


def search_table(found: dict, top=8) -> str:
    """The ``top`` rules by successes, as a Markdown table (1: the task's success within ``t_final``)."""
    score = found["success"].sum(axis=1)
    head = " | ".join(f"{name} {goal}" for name, goal in found["robots"])
    lines = [f"| margin | p | v | successes | {head} |", "|---" * (4 + len(found["robots"])) + "|"]
    for i in found["ranked"][:top]:
        rule = found["rules"][i]
        lines.append(f"| {rule.margin:g} | {rule.p:g} | {rule.v:g} | {score[i]} | "
                     + " | ".join(str(int(b)) for b in found["success"][i]) + " |")
    return "\n".join(lines)
