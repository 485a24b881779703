"""Counter-based Gaussian noise: the same numbers whatever thread, batch or order runs a rollout.

A draw is a function of (seed, rollout id, step, k) alone (SplitMix64 mixing, then Box-Muller). The integers
become floats by explicit conversions, as the Warp engine's translation of the same source needs
(:mod:`paa_mj.sim.warp.translate`; numba converts the same way where left implicit).
The engine uses k = i for the measurement noise of angle i, n + i for speed i, and 2n + j for the
torque noise of motor j (n links).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _mix(z):
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def gaussian(seed, rollout, step, k):
    """A standard normal number determined by (seed, rollout, step, k) alone (SplitMix64 + Box-Muller)."""
    z = _mix(np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(rollout))
    z = _mix(z ^ (np.uint64(step) * np.uint64(0xD1B54A32D192ED03) + np.uint64(k)))
    if z == np.uint64(0):  # the mixer's fixed point, reached by the all-zero counter: it would draw u1 = 2^-53, 8.6 sigma
        z = np.uint64(0x9E3779B97F4A7C15)
    u1 = np.float64((z >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740993.0)
    u2 = np.float64(_mix(z) >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
