"""Dynamic similarity between robots of the family: the scales that carry a number stated on one robot to another.

A robot's scales (:func:`robot_scales`) are its gravity torque G = sum_k b_k [N m] (the whole chain held level
about the bar), each motor's C_j = sum_{k >= a_j} b_k [N m] (the gravity torque motor j on joint a_j carries at
worst: the links beyond it held level) and its natural time T = 1 / lambda [s], lambda^2 the largest eigenvalue of
M(0)^-1 (-dG/dq)(0) (the rate of the fastest fall of the stretched chain balanced upright, motors off). Against a
reference robot (:data:`REFERENCE`, RealAIGym's acrobot, whose numbers the field states) a robot's ratios
(g, g_j, t) = (G / G_ref, C_j / C_ref, T / T_ref) are each exactly 1 on the reference and on any robot of its links
with the same motors. The model-predictive controller carries its options by them, and RealAIGym's score
normalisations are carried by them to a robot-scaled score (:mod:`paa_mj.realaigym.scores`).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from .dynamics import AnalyticModel

#: The robot every carried number is stated on.
REFERENCE = "realaigym_acrobot"


def robot_scales(model: AnalyticModel):
    """(G, C, T) of a robot (module docstring): G [N m], C (m,) [N m] one per motor, T [s]. The natural time is the
    fastest of the chain's falls, the motion a plan's knots must resolve; sqrt(I / G) of the whole chain's inertia
    I about the bar is slower than it by 2 to 5 on the family's robots."""
    b = model.gravity_constants
    q = np.zeros(model.n_links)
    rates = np.linalg.eigvals(np.linalg.solve(model.mass_matrix(q), -model.gravity_jacobian(q))).real
    return float(np.sum(b)), np.cumsum(b[::-1])[::-1][list(model.actuated)], 1.0 / math.sqrt(float(np.max(rates)))


@functools.lru_cache(maxsize=1)
def _reference():
    """(:func:`robot_scales`, number of links) of :data:`REFERENCE`."""
    from .robot import load_robot

    model = load_robot(REFERENCE).analytic
    return robot_scales(model), model.n_links


def similarity(model: AnalyticModel):
    """(g, g_j, t) = (G / G_ref, C_j / C_ref, T / T_ref) of :func:`robot_scales` against :data:`REFERENCE` (C_ref the
    largest of its motors'): each exactly 1 on it and on any robot of its links with the same motors."""
    (G, C, T), ((G0, C0, T0), _) = robot_scales(model), _reference()
    return G / G0, C / np.max(C0), T / T0


def links_ratio(model: AnalyticModel) -> float:
    """The robot's joints over :data:`REFERENCE`'s."""
    return model.n_links / _reference()[1]
