"""Gains against the theory: errors below the singularity bound (41), warnings outside Theorem 1."""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import PaaError
from ..model.dynamics import AnalyticModel
from ..theory.conditions import constraint_54, thresholds


class TheoryWarning(UserWarning):
    """Gains or robot outside what Theorem 1 covers; the run goes on."""


def check_gains(model: AnalyticModel, kD, kP, kV, stacklevel=3):
    """Validate gains of (40) (or (12)) against the theory for ``model``.

    Raises
    ------
    PaaError
        A gain that is not finite, kV <= 0, or kD <= kD_min of (41) (the
        controller can hit a singular Lambda (38)); the message names the bound
        and its value.

    Warns
    -----
    TheoryWarning
        kP <= eta1 (59) or eta2 (60), E_r <= 0, or constraint (54) fails: Theorem 1
        no longer guarantees convergence to W_r or DUU, but the run may go on.

    Returns
    -------
    list of str
        The warnings given.
    """
    for name, value in (("kD", kD), ("kP", kP), ("kV", kV)):
        if not np.isfinite(value):
            raise PaaError(f"gain {name} = {value} is not finite")
    if kV <= 0:
        raise PaaError(f"gain kV = {kV:g} must be > 0 (dV/dt = -kV |qd_a|^2 (36))")
    kd, e1, e2 = thresholds(model)
    if kD <= kd.value:
        raise PaaError(f"gain kD = {kD:g} is not above kD_min = {kd.value:.6g} of (41): controller (40) can become singular")
    messages = []
    if model.E_r <= 0:
        messages.append(f"E_r = {model.E_r:.6g} J <= 0: the method of the paper does not apply (9)")
    if kP <= e1.value:
        messages.append(f"kP = {kP:g} is not above eta1 = {e1.value:.6g} of (59): Theorem 1 no longer guarantees convergence")
    if kP <= e2.value:
        messages.append(f"kP = {kP:g} is not above eta2 = {e2.value:.6g} of (60): Theorem 1 no longer guarantees convergence")
    c54 = constraint_54(model)
    if not c54.holds:
        messages.append(f"constraint (54) fails (f(z) = 1 near z = {c54.z_closest:.4g}): Theorem 1 does not apply, the swing-up may stall")
    for message in messages:
        warnings.warn(message, TheoryWarning, stacklevel=stacklevel)
    return messages
