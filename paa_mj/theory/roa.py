"""The region of attraction of the balance LQR (67), with the torque limit: an inner estimate as a level set.

With x = [wrap(q - q*), qd] the error from the task's goal and (K, S) of (67) (:func:`~paa_mj.theory.linear.lqr_solution`:
S the stabilising solution of the LQR's Riccati equation, so :math:`V(x) = x^T S x` is the cost-to-go of the
linear loop and :math:`\\dot V = -x^T (Q + K^T R K) x` along it), the estimate is the ellipsoid

.. math::

    \\Omega_\\rho = \\{x : x^T S x \\le \\rho\\}

of the closed loop :math:`\\tau = \\mathrm{sat}(-K x)` of (1). Two methods (:data:`METHODS`):

- ``sos`` (Drake): :math:`\\rho = \\min(\\rho_{sos}, \\rho_u)`. :math:`\\rho_u = \\min_j u_j^2 / (K_j S^{-1}
  K_j^T)` is the largest level on which :math:`|K_j x| \\le u_j` for every motor j (closed form), so the loop is
  unsaturated on :math:`\\Omega_\\rho`; :math:`\\rho_{sos}` is certified by sums of squares
  (:mod:`paa_mj.theory.sos`) for the degree-3 Taylor model of the unsaturated loop. The remainder of the Taylor
  model is not bounded: the certificate holds for the polynomial model, and the true dynamics are checked on
  the set by sampling (:func:`vdot_check`);
- ``sampling``: an estimate, not a certificate: the largest level, by bisection, from whose boundary every one
  of ``samples`` seeded states reaches the goal in a simulation of (1) by RK4 at the control step with the
  torque held over each step and saturated, lowered below any of ``samples`` seeded states inside it that does
  not (:func:`simulated_level`), as RealAIGym's simulation-based estimates do.

Beside it: the spectral radius of the loop sampled with zero-order hold at the control step
(:func:`~paa_mj.theory.linear.sampled_spectral_radius`; above 1 the sampled balance is unstable and the
continuous-time set says nothing about the controller as it runs), and the fraction of the switch region (68)
inside the set (:func:`fraction_inside`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import PaaError
from ..limits import MAX_SECONDS, duration
from ..model.dynamics import AnalyticModel
from ..model.states import wrap
from ..progress import progress as progress_bar
from ..provenance import kept
from ..task import Task
from . import sos
from .linear import sampled_spectral_radius

METHODS = ("sos", "sampling")
#: States sampled: on the boundary per level of the simulated bisection; uniformly in the box of (68).
SIMULATED_SAMPLES = 64
BOX_SAMPLES = 100000
#: States sampled uniformly in the set to check dV/dt < 0 on the true dynamics (1) with saturation.
VDOT_SAMPLES = 20000
#: Levels tried by the simulated bisection (geometric, between 1e-8 and 1 of the bracket's top).
SIMULATED_BISECTIONS = 14
#: Each simulated state has to come within V < REACHED rho of the goal, in at least SIMULATED_HORIZON seconds
#: and twice the time the linear loop's slowest mode takes to get there (:func:`settling_time`).
SIMULATED_HORIZON = 5.0
REACHED = 1e-3
#: One core's seconds per RK4 step of :func:`simulate_errors` for SIMULATED_SAMPLES states of a chain of n links:
#: SIMULATED_STEP_SECONDS + SIMULATED_STEP_SECONDS_PER_LINK2 n^2 (measured here at the models' own steps: 0.92,
#: 1.0, 1.6, 4.1 and 10.6 ms at 3, 6, 12, 20 and 40 links).
SIMULATED_STEP_SECONDS = 9e-4
SIMULATED_STEP_SECONDS_PER_LINK2 = 6.5e-6


@dataclass(frozen=True)
class RegionOfAttraction:
    """An inner estimate :math:`x^T S x \\le \\rho` of the balance LQR's region of attraction (module docstring).

    Attributes
    ----------
    S : ndarray (2n, 2n)
        The Riccati solution of (67) [units of the LQR's cost: Q x^2 s].
    rho : float
        The level (0: the estimate is empty).
    method : {"sos", "sampling"}
    certified : bool
        True for ``sos``: certified for the Taylor model of ``taylor_degree`` (see ``certificate``).
    certificate : str
        What is certified, in words.
    rho_sos, rho_torque, rho_upper : float or None
        The SOS level, the unsaturated level of the torque limit (None without one), and an upper bound of any
        certifiable level (the Taylor model's dV/dt >= 0 on a sampled ray).
    u_max : list of float or None
        The torque limit [N m] per motor (None: none).
    dt : float
        The control step [s] (the robot's MJCF time step).
    spectral_radius : float
        Of the zero-order-hold loop at ``dt`` (below 1: the sampled balance is stable).
    vdot_check : dict
        dV/dt of the true dynamics (1) with saturation at states sampled uniformly in the set.
    fraction_of_switch_region_inside : dict
        ``fraction`` of ``samples`` states uniform in region (68) (seed ``seed``) that lie in the set.
    """

    S: np.ndarray
    rho: float
    method: str
    certified: bool
    certificate: str
    rho_sos: float | None
    rho_torque: float | None
    rho_upper: float | None
    u_max: list | None
    dt: float
    spectral_radius: float
    vdot_check: dict
    fraction_of_switch_region_inside: dict
    simulation: dict | None = None

    def to_dict(self) -> dict:
        out = asdict(self)
        out["S"] = np.asarray(self.S).tolist()
        return out


def torque_level(S, K, u_max):
    """:math:`\\rho_u = \\min_j u_j^2 / (K_j S^{-1} K_j^T)`: the largest level on whose ellipsoid every motor's
    :math:`|K_j x| \\le u_j` [N m] (the maximum of :math:`K_j x` on :math:`x^T S x = \\rho` is
    :math:`\\sqrt{\\rho\\, K_j S^{-1} K_j^T}`); None when no motor is limited."""
    if u_max is None:
        return None
    u_max = np.broadcast_to(np.asarray(u_max, float), (np.shape(K)[0],))
    limited = np.isfinite(u_max)
    if not np.any(limited):
        return None
    K = np.asarray(K, float)
    spread = np.einsum("ji,ik,jk->j", K, np.linalg.inv(S), K)
    return float(np.min(u_max[limited] ** 2 / spread[limited]))


def uniform_in_ellipsoid(S, rho, count, rng):
    """``count`` states uniform in :math:`x^T S x \\le \\rho` (errors from the goal), shape (count, 2n)."""
    width = S.shape[0]
    g = rng.standard_normal((count, width))
    g *= (rng.uniform(size=count) ** (1.0 / width) / np.linalg.norm(g, axis=1))[:, None]
    return np.sqrt(rho) * np.linalg.solve(np.linalg.cholesky(S).T, g.T).T


def on_ellipsoid(S, rho, count, rng):
    """``count`` states on :math:`x^T S x = \\rho`, directions uniform in the whitened coordinates."""
    g = rng.standard_normal((count, S.shape[0]))
    g /= np.linalg.norm(g, axis=1)[:, None]
    return np.sqrt(rho) * np.linalg.solve(np.linalg.cholesky(S).T, g.T).T


def _field(am, goal, K, u_max, x):
    """dx/dt of (1) under tau = sat(-K x) at errors ``x`` (N, 2n)."""
    n = goal.size
    tau = np.clip(-x @ K.T, -u_max, u_max)
    return np.concatenate([x[:, n:], am.acceleration(goal + x[:, :n], x[:, n:], tau)], axis=1)


def vdot_check(am, task, K, S, rho, u_max, samples=VDOT_SAMPLES, seed=0) -> dict:
    """dV/dt = 2 x^T S f(x) of the true closed loop (1) with saturation at ``samples`` seeded states uniform in
    the set: how many have dV/dt >= 0 (0 agrees with the certificate) and the largest dV/dt / V [1/s]."""
    if rho <= 0:
        return {"samples": 0, "seed": seed, "rising": 0, "max_rate": None}
    x = uniform_in_ellipsoid(S, rho, samples, np.random.default_rng(seed))
    limit = np.inf if u_max is None else np.asarray(u_max, float)
    rate = 2 * np.einsum("ki,ij,kj->k", x, S, _field(am, task.goal, K, limit, x))
    value = np.einsum("ki,ij,kj->k", x, S, x)
    return {"samples": samples, "seed": seed, "rising": int(np.sum(rate >= 0)),
            "max_rate": float(np.max(rate / value))}


def fraction_inside(task: Task, S, rho, samples=BOX_SAMPLES, seed=0) -> dict:
    """The fraction of the switch region (68) inside :math:`x^T S x \\le \\rho`: ``samples`` seeded states uniform
    in the box :math:`|x_i| <` angle, :math:`|x_{n+i}| <` speed of the task's switch region."""
    n, region = task.n_links, task.switch_region
    half = np.concatenate([np.full(n, region.angle), np.full(n, region.speed)])
    x = np.random.default_rng(seed).uniform(-1.0, 1.0, (samples, 2 * n)) * half
    inside = np.einsum("ki,ij,kj->k", x, S, x) <= rho
    return {"fraction": float(np.mean(inside)), "samples": samples, "seed": seed}


def simulate_errors(am: AnalyticModel, task: Task, K, u_max, dt, x0, horizon, S=None, stop_level=None, bar=None):
    """RK4 at ``dt`` [s] of (1) from errors ``x0`` (N, 2n), torque sat(-K x) held over each step [N m].

    Returns the errors at the end (N, 2n) (NaN where the state ran away). With ``S`` and ``stop_level``,
    stops early once every V(x) is below ``stop_level``. ``bar``, a progress bar, counts the steps."""
    goal, K = task.goal, np.asarray(K, float)
    limit = np.inf if u_max is None else np.asarray(u_max, float)
    n = goal.size
    x = np.array(x0, float)
    for step in range(int(round(horizon / dt))):
        if bar is not None and step % 256 == 255:
            bar.update(256)
        tau = np.clip(-x @ K.T, -limit, limit)

        def f(y):
            return np.concatenate([y[:, n:], am.acceleration(goal + y[:, :n], y[:, n:], tau)], axis=1)

        k1 = f(x)
        k2 = f(x + 0.5 * dt * k1)
        k3 = f(x + 0.5 * dt * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[:, :n] = wrap(x[:, :n])
        far = ~np.all(np.isfinite(x) & (np.abs(x) < 1e3), axis=1)
        x[far] = np.nan
        if np.any(far):
            return x
        if stop_level is not None and np.all(np.einsum("ki,ij,kj->k", x, S, x) < stop_level):
            break
    return x


def settling_time(am, task, K):
    """ln(1 / REACHED) / sigma [s], twice the time V of the linear loop's slowest mode (decay rate sigma [1/s] of
    its eigenvalue nearest the imaginary axis; V decays at 2 sigma) takes to fall to REACHED of its start."""
    A, B = am.linearize(task.goal)
    sigma = -float(np.max(np.linalg.eigvals(A - B @ np.asarray(K, float)).real))
    return float(np.log(1.0 / REACHED) / sigma) if sigma > 0 else float("inf")


def simulated_step_seconds(am: AnalyticModel, samples=SIMULATED_SAMPLES) -> float:
    """An estimate of one core's seconds per step of :func:`simulate_errors` for ``samples`` states."""
    per_step = SIMULATED_STEP_SECONDS + SIMULATED_STEP_SECONDS_PER_LINK2 * am.n_links ** 2
    return per_step * max(1.0, 0.5 + 0.5 * samples / SIMULATED_SAMPLES)


def simulated_level(am, task, K, S, u_max, dt, top, samples=SIMULATED_SAMPLES, seed=0,
                    horizon=None, bisections=SIMULATED_BISECTIONS, progress=False) -> dict:
    """The ``sampling`` estimate: geometric bisection on rho in [1e-8 top, top] of "every one of ``samples``
    seeded states on x^T S x = rho comes within V < REACHED rho of the goal in ``horizon`` seconds"
    (:func:`simulate_errors`, the same seed at every level; default horizon the larger of SIMULATED_HORIZON and
    :func:`settling_time`), then ``samples`` seeded states uniform inside the level found: where some fail, the
    level drops below the least V at which one started, and the inside is sampled again (up to ``bisections``
    times), since a boundary that returns says nothing of the states within. 0.0 when the lowest level fails.
    Refused in one line where its steps would take more than a day (:func:`simulated_step_seconds`); with
    ``progress``, a bar on stderr counts them."""
    rng_seed = np.random.SeedSequence(seed)
    inside_seed = np.random.SeedSequence([seed, 1])
    if horizon is None:
        horizon = max(SIMULATED_HORIZON, settling_time(am, task, K))
    if not np.isfinite(horizon):
        return {"rho": 0.0, "at_top": False, "samples": samples, "seed": seed, "horizon": None}

    steps, levels = int(round(horizon / dt)), bisections + 3
    need = steps * levels * simulated_step_seconds(am, samples)
    if not need <= MAX_SECONDS:
        raise PaaError(f"the sampling estimate would simulate up to {levels} levels of {steps:.3g} steps of {dt:g} s"
                       f" ({samples} states each), about {duration(need)} of computing (the limit is"
                       f" {duration(MAX_SECONDS)})" + (f"; use --method sos (up to {sos.SOS_MAX_LINKS} links)"
                                                       if am.n_links <= sos.SOS_MAX_LINKS else ""))
    bar = progress_bar(desc="region of attraction, simulated levels", unit="step", total=steps * levels,
                       enabled=progress)

    def failed_from(x0, level):
        """V at the start of each state of x0 that does not reach V < REACHED level."""
        x = simulate_errors(am, task, K, u_max, dt, x0, horizon, S, REACHED * level, bar)
        missed = ~(np.einsum("ki,ij,kj->k", x, S, x) < REACHED * level)
        return np.einsum("ki,ij,kj->k", x0, S, x0)[missed]

    def reached(level):
        return failed_from(on_ellipsoid(S, level, samples, np.random.default_rng(rng_seed)), level).size == 0

    def inside(level):
        """The level, lowered below every state inside it seen to fail."""
        for _ in range(bisections):
            failed = failed_from(uniform_in_ellipsoid(S, level, samples, np.random.default_rng(inside_seed)), level)
            if failed.size == 0:
                return level, True
            level = 0.99 * float(np.min(failed))
        return level, False

    def estimate(level, at_top):
        rho, checked = inside(level)
        return {"rho": float(rho) if checked else 0.0, "at_top": at_top and rho == level, "samples": samples,
                "seed": seed, "horizon": horizon}

    with bar:
        low, high = np.log(1e-8 * top), np.log(top)
        if reached(top):
            return estimate(float(top), True)
        if not reached(np.exp(low)):
            return {"rho": 0.0, "at_top": False, "samples": samples, "seed": seed, "horizon": horizon}
        for _ in range(bisections):
            middle = 0.5 * (low + high)
            low, high = (middle, high) if reached(np.exp(middle)) else (low, middle)
        return estimate(float(np.exp(low)), False)


def angle_level(S, n):
    """The level whose ellipsoid just reaches an angle error of pi [rad]: :math:`\\pi^2 / \\max_i (S^{-1})_{ii}`
    over the angles (beyond it the wrapped error and V disagree)."""
    return float(np.pi ** 2 / np.max(np.diag(np.linalg.inv(S))[:n]))


def choose_method(method, n_links):
    """``method`` checked, or the default: sos where Drake imports and the chain is small enough
    (:data:`~paa_mj.theory.sos.SOS_MAX_LINKS`), else sampling."""
    if method is None:
        return "sos" if sos.drake_available() and n_links <= sos.SOS_MAX_LINKS else "sampling"
    if method not in METHODS:
        raise PaaError(f"unknown region-of-attraction method {method!r}: use one of {', '.join(METHODS)}")
    if method == "sos":
        if not sos.drake_available():
            raise PaaError("the sos method needs Drake (pip install 'paa_mj[peers]'); use --method sampling")
        if n_links > sos.SOS_MAX_LINKS:
            raise PaaError(f"the sos method is limited to chains of {sos.SOS_MAX_LINKS} links (its programs grow as"
                           f" (2n)^4), got {n_links}; use --method sampling")
    return method


def _sos_part(am, task, K, S, Q, R, rho_torque):
    """(rho, rho_sos, rho_upper, certificate) of the sos method.

    (rho_sos, rho_upper) depend on the loop (K, S, Q, R) alone, not on the torque limit or the step: they are kept
    on disk by that content (:func:`~paa_mj.provenance.kept`), so a region of attraction, a switch level and the
    same loop under another torque limit share one sums-of-squares program (about 6 CPU-s for the gymnast)."""
    lower = np.linalg.cholesky(S)
    decrease = np.linalg.solve(lower, np.linalg.solve(lower, Q + K.T @ R @ K).T)
    epsilon = sos.EPSILON_FRACTION * float(np.linalg.eigvalsh(0.5 * (decrease + decrease.T))[0])

    def compute():
        terms = sos.taylor_field(am, task, K, sos.TAYLOR_DEGREE)
        upper = sos.sampled_bound(terms, S)
        top = angle_level(S, am.n_links) if upper is None else min(upper, angle_level(S, am.n_links))
        return sos.sos_level(S, terms, epsilon, top)[0], upper

    rho_sos, upper = kept("sos_level", compute, encode=lambda r: {"rho_sos": r[0], "upper": r[1]},
                          decode=lambda d: (float(d["rho_sos"]), None if d["upper"] is None else float(d["upper"])),
                          **_definition(am, task, Q, R, None, 0.0, "sos", K=np.asarray(K, float),
                                        S=np.asarray(S, float), degree=sos.TAYLOR_DEGREE))
    rho = rho_sos if rho_torque is None else min(rho_sos, rho_torque)
    certificate = (f"dV/dt <= -{epsilon:.3g} |L^T x|^2 < 0 on 0 < x^T S x <= rho (S = L L^T) for the degree-"
                   f"{sos.TAYLOR_DEGREE} Taylor model of the unsaturated loop about the goal, by sums of squares"
                   " (Drake, Clarabel); the Taylor remainder is not bounded, so the true dynamics are only checked"
                   " by sampling (vdot_check)"
                   + ("" if rho_torque is None else "; rho <= rho_torque keeps |K x| within the torque limit"))
    return rho, rho_sos, upper, certificate


def _finite_limits(u_max, n_motors):
    """Each motor's torque limit (m,) [N m], or None where ``u_max`` is None or limits none of them."""
    limits = None if u_max is None else np.broadcast_to(np.asarray(u_max, float), (n_motors,))
    return limits if limits is not None and np.any(np.isfinite(limits)) else None


def region_of_attraction(am: AnalyticModel, task: Task, K, S, Q, R, *, u_max=None, dt, method=None,
                         samples=SIMULATED_SAMPLES, seed=0, box_samples=BOX_SAMPLES,
                         vdot_samples=VDOT_SAMPLES, progress=False) -> RegionOfAttraction:
    """The inner estimate of the region of attraction of (67) with the torque limit ``u_max`` (module docstring).

    Parameters
    ----------
    am : AnalyticModel
    task : Task
        The goal (and region (68) for the fraction inside).
    K, S : ndarray
        (K, S) of :func:`~paa_mj.theory.linear.lqr_solution` with weights Q, R.
    u_max : float, (m,) or None
        Torque limit per motor [N m] (inf or None: none).
    dt : float
        The control step [s].
    method : {"sos", "sampling"} or None
        None: :func:`choose_method`.
    samples, seed : int
        States per level of the ``sampling`` method; the seed of every sample.
    progress : bool
        A progress bar on stderr while the ``sampling`` method simulates.

    The region is kept on disk by its content (:func:`~paa_mj.provenance.kept`: the robot, task, weights, gains,
    limits, step, method and samples, and the package's code): asked again, it is read back, not recomputed.
    """
    K, S = np.asarray(K, float), np.asarray(S, float)
    method = choose_method(method, am.n_links)
    limits = _finite_limits(u_max, am.n_motors)

    def compute():
        return _region_of_attraction(am, task, K, S, Q, R, limits, dt, method, samples, seed, box_samples,
                                     vdot_samples, progress)

    return kept("region_of_attraction", compute, encode=RegionOfAttraction.to_dict,
                decode=lambda d: RegionOfAttraction(**{**d, "S": np.asarray(d["S"], float)}),
                **_definition(am, task, Q, R, limits, dt, method, K=K, S=S, samples=samples, seed=seed,
                              box_samples=box_samples, vdot_samples=vdot_samples))


def _region_of_attraction(am, task, K, S, Q, R, limits, dt, method, samples, seed, box_samples, vdot_samples,
                          progress) -> RegionOfAttraction:
    rho_torque = torque_level(S, K, limits)
    simulation = None
    if method == "sos":
        rho, rho_sos, upper, certificate = _sos_part(am, task, K, S, Q, R, rho_torque)
    else:
        rho_sos, upper = None, None
        simulation = simulated_level(am, task, K, S, limits, dt, angle_level(S, am.n_links), samples, seed,
                                     progress=progress)
        rho = simulation["rho"]
        certificate = (f"none: an estimate from {samples} seeded states on the boundary of each level tried and"
                       f" {samples} inside the level kept, simulated by RK4 at dt with the torque held and saturated")
    return RegionOfAttraction(
        S=S, rho=float(rho), method=method, certified=method == "sos", certificate=certificate, rho_sos=rho_sos,
        rho_torque=rho_torque, rho_upper=upper, u_max=None if limits is None else limits.tolist(), dt=float(dt),
        spectral_radius=sampled_spectral_radius(am, K, dt, task),
        vdot_check=vdot_check(am, task, K, S, rho, limits, vdot_samples, seed),
        fraction_of_switch_region_inside=fraction_inside(task, S, rho, box_samples, seed), simulation=simulation)


def switch_level(am: AnalyticModel, task: Task, Q, R, *, u_max=None, dt, method=None):
    """(S, rho) of the set x^T S x <= rho for a switch to (67) (:class:`~paa_mj.control.combined.LevelCondition`):
    the ``rho`` of :func:`region_of_attraction` without its checks; kept per robot, task, weights, limits, step and
    method, in memory (every controller built for a study's runs asks again) and on disk by content
    (:func:`~paa_mj.provenance.kept`: every run of ``--controller vc-roa`` asked for it again, 42 CPU-s)."""
    from .linear import lqr_solution

    method = choose_method(method, am.n_links)
    limits = _finite_limits(u_max, am.n_motors)
    Q, R = np.asarray(Q, float), np.asarray(R, float)
    key = (am.key(), task, Q.tobytes(), R.tobytes(), None if limits is None else limits.tobytes(), float(dt), method)
    if key not in _SWITCH_LEVELS:
        def compute():
            K, S = lqr_solution(am, task, Q, R)
            rho_torque = torque_level(S, K, limits)
            if method == "sos":
                return S, _sos_part(am, task, K, S, Q, R, rho_torque)[0]
            return S, simulated_level(am, task, K, S, limits, dt, angle_level(S, am.n_links))["rho"]

        _SWITCH_LEVELS[key] = kept("switch_level", compute, encode=lambda r: {"S": np.asarray(r[0]).tolist(),
                                                                              "rho": float(r[1])},
                                   decode=lambda d: (np.asarray(d["S"], float), float(d["rho"])),
                                   **_definition(am, task, Q, R, limits, dt, method))
    S, rho = _SWITCH_LEVELS[key]
    return S.copy(), rho


def _definition(am, task, Q, R, limits, dt, method, **more) -> dict:
    """What a kept level or region of attraction is made of (:func:`~paa_mj.provenance.kept`)."""
    return dict(robot=am.key(), task=task.key(), Q=np.asarray(Q, float), R=np.asarray(R, float),
                limits=None if limits is None else np.asarray(limits, float), dt=float(dt), method=method, **more)


_SWITCH_LEVELS: dict = {}
