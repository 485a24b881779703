"""Physical parameters of a planar chain on the bar: the gymnast and its family (``docs/model.md``).

A :class:`RobotParams` holds, for each of its n >= 2 links i, its mass ``m_i`` [kg],
length ``l_i`` [m], distance ``lc_i`` [m] from joint i to its centre of mass, moment
of inertia ``J_i`` [kg m^2] about the centre of mass, the viscous damping ``d_i``
[N m s/rad] and the armature ``a_i`` [kg m^2] of joint i, plus gravity ``g``
[m/s^2]. The paper's gymnast is n = 3 without damping or armature (Table 1). The
named robots live in ``models/*.xml``; parameters are read back from the compiled
MuJoCo model (:func:`paa_mj.model.mjcf_read.params_from_model`) so the analytic model
is always the one MuJoCo runs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import PaaError

#: Plausible ranges of the parameters: outside them a model is refused as absurd (its
#: energies would overflow or vanish below rounding). Damping and armature may also be 0.
PLAUSIBLE = {"m": (1e-6, 1e6), "l": (1e-4, 1e3), "J": (1e-10, 1e9), "damping": (0.0, 1e9), "armature": (0.0, 1e9)}
#: Plausible range of gravity [m/s^2]: from a millionth of the Earth's to a hundred times it.
PLAUSIBLE_GRAVITY = (1e-5, 1e3)
#: The most links of a chain (a limit of sense, not of the formulas: the cost of a step grows as n^3).
MAX_LINKS = 64
#: Per-link parameters, in their order; damping and armature may be left out (zero).
PER_LINK = ("m", "l", "lc", "J", "damping", "armature")


def _per_link(name, value, n=None):
    arr = np.array(value, dtype=float).reshape(-1)
    if n is None:
        if not 2 <= arr.size <= MAX_LINKS:
            raise PaaError(f"{name} needs one value per link, for 2 to {MAX_LINKS} links, got {arr.size}")
    elif arr.size == 1 and name in ("damping", "armature"):
        arr = np.full(n, float(arr[0]))
    elif arr.size != n:
        raise PaaError(f"{name} needs {n} values (one per link), got {arr.size}")
    return arr


def _check_range(key, values):
    """One per-link parameter: finite, > 0 (>= 0 for damping and armature) and within :data:`PLAUSIBLE`."""
    if not np.all(np.isfinite(values)):
        raise PaaError(f"non-physical parameters: {key} = {np.asarray(values).tolist()} is not finite")
    zero_allowed = key in ("damping", "armature")
    bad = np.flatnonzero(values < 0 if zero_allowed else values <= 0)
    if bad.size:
        i = bad[0]
        raise PaaError(f"non-physical parameters: {key}{i + 1} = {values[i]:g} must be {'>=' if zero_allowed else '>'} 0")
    low, high = PLAUSIBLE[key]
    bad = np.flatnonzero((values < low) | (values > high))
    if bad.size:
        i = bad[0]
        raise PaaError(f"non-physical parameters: {key}{i + 1} = {values[i]:g} lies outside the plausible"
                       f" range [{low:g}, {high:g}]")


def _actuated(value, n) -> tuple:
    """The driven joints (0-based, increasing) from ``value``, default 1..n-1; a one-line error otherwise."""
    if value is None:
        return tuple(range(1, n))
    try:
        joints = tuple(int(j) for j in value)
        if any(j != v for j, v in zip(joints, value)):
            raise ValueError
    except (TypeError, ValueError):
        raise PaaError(f"the driven joints must be joint indices, got {value!r}") from None
    if list(joints) != sorted(set(joints)) or any(not 0 <= j < n for j in joints):
        raise PaaError(f"the driven joints {[j + 1 for j in joints]} must be distinct joints of 1..{n} in increasing"
                       " order")
    if not 1 <= len(joints) <= n - 1:
        raise PaaError(f"a chain of {n} links needs at least one motor and at least one passive joint (the family is"
                       f" underactuated), got motors on joints {[j + 1 for j in joints]}")
    return joints


def _ranges(joints) -> str:
    """1-based joint numbers of 0-based ``joints``, runs written a..b: "1", "2..4", "1, 3"."""
    parts, start = [], None
    for k, j in enumerate(joints):
        if start is None:
            start = j
        if k + 1 == len(joints) or joints[k + 1] != j + 1:
            parts.append(f"{start + 1}" if start == j else f"{start + 1}..{j + 1}" if j > start + 1
                         else f"{start + 1}, {j + 1}")
            start = None
    return ", ".join(parts)


def actuation_text(n, actuated) -> str:
    """Which joints of an n-link chain carry motors, in words: "joint 1 passive, joints 2..3 driven"."""
    passive = [i for i in range(n) if i not in actuated]
    return (f"joint{'s' if len(passive) > 1 else ''} {_ranges(passive)} passive, joint{'s' if len(actuated) > 1 else ''}"
            f" {_ranges(list(actuated))} driven")


@dataclass(frozen=True, eq=False)
class RobotParams:
    """Masses, lengths, COM distances, inertias, joint damping and armature of the n links.

    Parameters
    ----------
    m, l, lc, J : array_like, shape (n,), 2 <= n <= :data:`MAX_LINKS`
        Link masses [kg], lengths [m], joint-to-COM distances [m] and
        moments of inertia about the COM [kg m^2].
    g : float
        Gravitational acceleration [m/s^2], positive.
    damping : array_like, shape (n,) or scalar, optional
        Viscous damping of each joint [N m s/rad] (MuJoCo's joint ``damping``), >= 0; default 0.
    armature : array_like, shape (n,) or scalar, optional
        Rotor inertia added to each joint [kg m^2] (MuJoCo's ``armature``), >= 0; default 0.
    actuated : sequence of int, optional
        The joints that carry a motor, 0-based and increasing (motor k drives joint ``actuated[k]``), at least one
        and not all: the input matrix B of (1) is the identity's columns ``actuated``. Default: joints 2..n
        (``1..n-1``), joint 1 (the hands on the bar) passive, the paper's family; (0,) with two links is a
        pendubot.

    Raises
    ------
    PaaError
        For non-physical values: m <= 0, J <= 0, l <= 0, lc outside [0, l],
        damping or armature < 0, g <= 0, anything non-finite, values outside
        :data:`PLAUSIBLE`, or arrays of different lengths; for ``actuated`` that is
        not a strictly increasing subset of the joints with at least one motor and
        one passive joint.
    """

    m: np.ndarray
    l: np.ndarray
    lc: np.ndarray
    J: np.ndarray
    g: float = 9.81
    name: str = field(default="custom", compare=False)
    damping: np.ndarray | None = None
    armature: np.ndarray | None = None
    actuated: tuple | None = None

    def __post_init__(self):
        n = _per_link("m", self.m).size
        for key in PER_LINK:
            value = getattr(self, key)
            object.__setattr__(self, key, np.zeros(n) if value is None else _per_link(key, value, n))
        object.__setattr__(self, "g", float(self.g))
        object.__setattr__(self, "actuated", _actuated(self.actuated, n))
        self.validate()

    def __repr__(self):
        extra = "".join(f", {key}={getattr(self, key)!r}" for key in ("damping", "armature")
                        if np.any(getattr(self, key)))
        if not self.passive_first:
            extra += f", actuated={self.actuated!r}"
        return (f"RobotParams(m={self.m!r}, l={self.l!r}, lc={self.lc!r}, J={self.J!r}, g={self.g!r},"
                f" name={self.name!r}{extra})")

    @property
    def n_links(self) -> int:
        """The number of links n (and of joints)."""
        return int(self.m.size)

    @property
    def n_motors(self) -> int:
        """The number of motors m (joints that carry one: :attr:`actuated`)."""
        return len(self.actuated)

    @property
    def passive(self) -> tuple:
        """The joints without a motor, 0-based."""
        return tuple(i for i in range(self.n_links) if i not in self.actuated)

    @property
    def passive_first(self) -> bool:
        """Joint 1 passive and joints 2..n driven: the paper's family, where its theory and controllers apply."""
        return self.actuated == tuple(range(1, self.n_links))

    @property
    def input_matrix(self) -> np.ndarray:
        """B of (1), shape (n, m): column k is the unit vector of joint ``actuated[k]``."""
        return np.eye(self.n_links)[:, list(self.actuated)]

    def actuation_meta(self) -> dict:
        """What a run's metadata records of the motors: ``{"driven_joints": [...]}`` (1-based) where joint 1 is not
        the only passive one, else nothing (the paper's family, as every run recorded before)."""
        return {} if self.passive_first else {"driven_joints": [j + 1 for j in self.actuated]}

    def actuation_text(self) -> str:
        """The motors in words, for headers and messages: "joint 1 passive, joints 2..3 driven"."""
        return actuation_text(self.n_links, self.actuated)

    @property
    def is_paper_shape(self) -> bool:
        """Three links without damping or armature, joint 1 passive: the model (1)-(7) of the paper holds as
        written."""
        return (self.n_links == 3 and not np.any(self.damping) and not np.any(self.armature)
                and self.passive_first)

    def validate(self):
        for key in PER_LINK:
            if not np.all(np.isfinite(getattr(self, key))):
                raise PaaError(f"non-physical parameters: {key} = {getattr(self, key).tolist()} is not finite")
        for key in ("m", "l", "J", "damping", "armature"):
            _check_range(key, getattr(self, key))
        bad = np.flatnonzero((self.lc < 0) | (self.lc > self.l))
        if bad.size:
            i = bad[0]
            raise PaaError(
                f"non-physical parameters: lc{i + 1} = {self.lc[i]:g} must lie in [0, l{i + 1}] = [0, {self.l[i]:g}]")
        if not (np.isfinite(self.g) and self.g > 0):
            raise PaaError(f"non-physical parameters: g = {self.g:g} must be > 0")
        low, high = PLAUSIBLE_GRAVITY
        if not low <= self.g <= high:
            raise PaaError(f"non-physical parameters: g = {self.g:g} m/s^2 lies outside the plausible range"
                           f" [{low:g}, {high:g}]")

    @classmethod
    def uniform_rods(cls, m, l, g=9.81, name="custom", damping=None, armature=None, actuated=None):
        """Slender uniform rods: lc = l / 2 and J = m l^2 / 12 (as Table 2 of the paper)."""
        m = _per_link("m", m)
        l = _per_link("l", l, m.size)
        for key, values in (("m", m), ("l", l)):  # before J is made of them (1e300 m would overflow it)
            _check_range(key, values)
        return cls(m=m, l=l, lc=l / 2, J=m * l**2 / 12, g=g, name=name, damping=damping, armature=armature,
                   actuated=actuated)

    def key(self) -> tuple:
        """The parameters as one hashable tuple (m, l, lc, J, g, then damping and armature where any is set, then
        -1 and the driven joints where joint 1 is not the only passive one: no parameter is negative)."""
        extra = [self.damping, self.armature] if np.any(self.damping) or np.any(self.armature) else []
        key = tuple(np.concatenate([self.m, self.l, self.lc, self.J, [self.g], *extra]).tolist())
        return key if self.passive_first else key + (-1.0,) + tuple(float(j) for j in self.actuated)

    def __eq__(self, other):
        return isinstance(other, RobotParams) and self.key() == other.key()

    def __hash__(self):
        return hash(self.key())

    def as_dict(self):
        """The parameters for JSON; damping and armature appear where any is set."""
        out = {"m": self.m.tolist(), "l": self.l.tolist(), "lc": self.lc.tolist(), "J": self.J.tolist(), "g": self.g}
        for key in ("damping", "armature"):
            if np.any(getattr(self, key)):
                out[key] = getattr(self, key).tolist()
        if not self.passive_first:
            out["actuated"] = [i + 1 for i in self.actuated]  # 1-based joints, as every message counts them
        return out

    def scaled(self, mass_factor=1.0, length_factor=1.0):
        """Return a copy with masses (and inertias) and lengths scaled, for model-error studies.

        Inertias scale as m l^2, so a rod stays a rod; damping and armature are kept.
        """
        return RobotParams(m=self.m * mass_factor, l=self.l * length_factor,
                           lc=self.lc * length_factor,
                           J=self.J * mass_factor * length_factor**2, g=self.g,
                           name=f"{self.name}*", damping=self.damping, armature=self.armature,
                           actuated=self.actuated)
