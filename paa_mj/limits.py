"""Bounded requests: every run is checked against memory and time before anything is allocated.

A request that would need more than the machine can give is refused with one
line that says what it would need and which options lower it.
"""
from __future__ import annotations

import math
import numbers
import os

import numpy as np

from .errors import PaaError

#: Fraction of the available memory one request may take.
MEMORY_FRACTION = 0.5
#: Longest run accepted [s of wall time], estimated by :func:`step_seconds` per physics step and core.
MAX_SECONDS = 24 * 3600.0
#: One core's seconds per physics step of a closed loop (the batch engine, RK4, controller (40)) of n links:
#: STEP_SECONDS + STEP_SECONDS_PER_LINK2 n^2, measured on this project's machine (18, 26, 33, 66 and 264 us at 3,
#: 6, 12, 20 and 40 links, runs of 8 rollouts; 11.5 us at 3 links in ``paa-mj bench``).
STEP_SECONDS = 1e-5
STEP_SECONDS_PER_LINK2 = 1.6e-7
#: Work estimated at more than this [s of wall time] is announced before it starts: its estimate and what lowers it.
ANNOUNCE_SECONDS = 60.0
#: Memory of one sub-environment of the vector environment on the CPU (its MjData, its episode's bookkeeping)
#: [bytes]: 315 KB measured for the gymnast between 500 and 2500 environments, 400 KB for 1000 (fixed costs
#: included); taken as 400 KB.
ENV_BYTES = 4e5


def available_memory() -> int:
    """Bytes of memory available now (MemAvailable on Linux, else total physical memory)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 8 << 30


def _gib(n):
    return f"{n / 2**30:.3g} GiB"


def check_memory(nbytes: float, what: str, lower: str, budget: float | None = None, where: str = "this machine"):
    """Refuse a request of ``nbytes`` for ``what`` above the budget (default: :data:`MEMORY_FRACTION` of this
    machine's available memory; ``where`` names another, a GPU); ``lower`` names the options to lower."""
    budget = MEMORY_FRACTION * available_memory() if budget is None else budget
    if not math.isfinite(nbytes) or nbytes > budget:
        raise PaaError(f"would need {_gib(nbytes)} of {what} ({where} can give {_gib(budget)}); lower {lower}")


def duration(seconds) -> str:
    """A duration in words: seconds, minutes, hours, days or years."""
    for unit, size in (("years", 3.15e7), ("days", 86400.0), ("hours", 3600.0), ("minutes", 60.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.2g} {unit}"
    return f"{seconds:.0f} s"


def step_seconds(links: int = 3) -> float:
    """One core's seconds per physics step of a closed loop of ``links`` links (an estimate, module constants)."""
    return STEP_SECONDS + STEP_SECONDS_PER_LINK2 * links * links


def check_steps(steps: float, what: str, lower: str, cores: int | None = None, links: int = 3,
                runs: float | None = None):
    """Refuse a run of ``steps`` physics steps of a chain of ``links`` links estimated to take longer than
    :data:`MAX_SECONDS` of wall time on ``cores`` cores (default this machine's), no more of them than ``runs``
    rollouts can use."""
    cores = cores or os.cpu_count() or 1
    if runs is not None:
        cores = max(1, min(cores, int(runs)))
    seconds = steps * step_seconds(links) / cores
    if not math.isfinite(seconds) or seconds > MAX_SECONDS:
        days = seconds / 86400
        raise PaaError(f"would need {steps:.3g} physics steps for {what}, about {days:.3g} days here"
                       f" (the limit is {MAX_SECONDS / 86400:g} days); lower {lower}")
    if seconds > ANNOUNCE_SECONDS:  # accepted, but said before it starts, with what would shorten it
        from .progress import stage

        stage(f"paa-mj: {steps:.3g} physics steps for {what}: about {duration(seconds)} here (an estimate); lower"
              f" {lower} to shorten it")


def check_seconds(seconds: float, what: str, lower: str):
    """Refuse work other than physics steps (:func:`check_steps`) estimated at more than :data:`MAX_SECONDS` of wall
    time, ``seconds``, in one line naming ``lower``, the options that shorten it; announce it past
    :data:`ANNOUNCE_SECONDS`."""
    if not math.isfinite(seconds) or seconds > MAX_SECONDS:
        raise PaaError(f"would need about {duration(seconds)} for {what} here (the limit is"
                       f" {MAX_SECONDS / 86400:g} days); lower {lower}")
    if seconds > ANNOUNCE_SECONDS:
        from .progress import stage

        stage(f"paa-mj: {what}: about {duration(seconds)} here (an estimate); lower {lower} to shorten it")


#: Largest gain of (40) accepted for the paper's robots [J kg m^2 and kin]: 1e8 times the paper's gains (66).
MAX_GAIN = 1e12
#: Largest gain accepted for any robot, as a multiple of its own gain scale (:func:`gain_scale`): the family rule's
#: gains of the stored robots are 0.01 to 0.3 of it (both goals), so a million times it leaves every plausible
#: robot (:data:`paa_mj.model.params.PLAUSIBLE`) its gains, a 1e6-kg gymnast included.
MAX_GAIN_PER_SCALE = 1e6


def gain_scale(m, l, g) -> float:
    """A robot's own scale of the gains of (40) [kg^2 m^4 s^-2, the unit of kD]: (sum m)^2 (sum l)^3 g, from its
    masses ``m`` [kg], lengths ``l`` [m] and gravity ``g`` [m/s^2]. kD_min (41) grows as m^2 l^3 g under a uniform
    scaling of masses and lengths; so does this."""
    return float(sum(m)) ** 2 * float(sum(l)) ** 3 * float(g)


def max_gain(m=None, l=None, g=None) -> float:
    """The largest gain accepted for a robot of masses ``m``, lengths ``l`` and gravity ``g`` (any of them None: no
    robot named): :data:`MAX_GAIN`, or :data:`MAX_GAIN_PER_SCALE` times its :func:`gain_scale` where that is more.
    The one limit every command applies to gains (:func:`paa_mj.control.gains.check_gain_range`), ``make-model``
    included, which refuses a robot whose gains would lie above it."""
    if m is None or l is None or g is None:
        return MAX_GAIN
    return max(MAX_GAIN, MAX_GAIN_PER_SCALE * gain_scale(m, l, g))


def positive_finite(name: str, value, allow_none=True):
    """``value`` as a float, refusing NaN, inf, zero and negative numbers with one line."""
    if value is None and allow_none:
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise PaaError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(number) and number > 0):
        raise PaaError(f"{name} must be a positive finite number, got {value}")
    return number


#: The seeds each random generator of the package takes, [0, limit): NumPy's legacy ``RandomState`` (RealAIGym's
#: protocols draw from it as their code does) seeds from 32-bit words; the noise streams of the batch engines key
#: their draws with an int64; ``numpy.random.default_rng`` takes any whole number >= 0.
SEED_LIMITS = {"numpy.random.RandomState": int(np.iinfo(np.uint32).max) + 1,
               "the noise streams (int64)": int(np.iinfo(np.int64).max) + 1,
               "numpy.random.default_rng": math.inf}
#: The one range of every seed, every ``--seed`` of every command and every ``seed=`` of the studies: the narrowest
#: of :data:`SEED_LIMITS`, so that a seed one command takes, every other takes too (2^32).
SEED_LIMIT = min(SEED_LIMITS.values())
SEED_RANGE = f"[0, 2^{SEED_LIMIT.bit_length() - 1})"


def seed_refusal(seed, shown=None):
    """None for a seed in [0, :data:`SEED_LIMIT`), else the reason it is refused (one phrase ending in ``shown``, by
    default the seed's repr)."""
    if not (isinstance(seed, numbers.Integral) and not isinstance(seed, bool) and 0 <= seed < SEED_LIMIT):
        shown = repr(seed) if shown is None else shown
        return (f"must be a whole number in {SEED_RANGE} (the seeds of NumPy's legacy generator, the narrowest the"
                f" package feeds), got {shown}")
    return None


def check_seed(seed, name="seed"):
    """``seed`` as a whole number in [0, :data:`SEED_LIMIT`) (what every generator of the package takes), or a
    one-line error naming ``name``."""
    refused = seed_refusal(seed)
    if refused is not None:
        raise PaaError(f"{name} {refused}")
    return int(seed)


#: A torque scale below this fraction of the robot's gravity torque (its largest gravity constant b_k [J], the
#: torque that holds link k level) moves nothing: a scale derived from a run that barely acted.
MIN_TORQUE_FRACTION = 1e-6


def physical_torque_scale(value, robot, what: str, lower: str = "give the scale yourself") -> float:
    """``value`` [N m], a torque scale derived from a study's own task and robot (a peak torque, a default limit),
    checked to be physical: finite and at least :data:`MIN_TORQUE_FRACTION` of the robot's gravity torque.

    Raises
    ------
    PaaError
        One line naming ``what``, its value, the robot's scale, and ``lower`` (what to do instead).
    """
    gravity = float(max(abs(float(b)) for b in robot.analytic.gravity_constants))
    scale = float(value)
    if not (math.isfinite(scale) and scale >= MIN_TORQUE_FRACTION * gravity):
        raise PaaError(f"{what} is {scale:.3g} N m, not a physical torque scale for robot {robot.name} (its gravity"
                       f" torque is {gravity:.4g} N m; at least {MIN_TORQUE_FRACTION:g} of it is needed): {lower}")
    return scale
