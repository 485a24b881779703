"""Physical parameters of the three-link gymnast (``docs/model.md``, section 1).

A :class:`RobotParams` holds, for each link i, its mass ``m_i`` [kg], length
``l_i`` [m], distance ``lc_i`` [m] from joint i to its centre of mass and moment
of inertia ``J_i`` [kg m^2] about the centre of mass, plus gravity ``g`` [m/s^2].
The named robots of the paper live in ``paa_mj/model/*.xml``; parameters are read
back from the compiled MuJoCo model (:func:`paa_mj.model.mjcf.params_from_model`)
so the analytic model is always the one MuJoCo runs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import PaaError

#: Plausible ranges of the parameters: outside them a model is refused as absurd (its
#: energies would overflow or vanish below rounding).
PLAUSIBLE = {"m": (1e-6, 1e6), "l": (1e-4, 1e3), "J": (1e-10, 1e9)}


def _vec3(name, value):
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.shape != (3,):
        raise PaaError(f"{name} needs 3 values (one per link), got {arr.size}")
    return arr


@dataclass(frozen=True, eq=False)
class RobotParams:
    """Masses, lengths, COM distances and inertias of the three links.

    Parameters
    ----------
    m, l, lc, J : array_like, shape (3,)
        Link masses [kg], lengths [m], joint-to-COM distances [m] and
        moments of inertia about the COM [kg m^2].
    g : float
        Gravitational acceleration [m/s^2], positive.

    Raises
    ------
    PaaError
        For non-physical values: m <= 0, J <= 0, l <= 0, lc outside [0, l],
        g <= 0, anything non-finite, or values outside :data:`PLAUSIBLE`.
    """

    m: np.ndarray
    l: np.ndarray
    lc: np.ndarray
    J: np.ndarray
    g: float = 9.81
    name: str = field(default="custom", compare=False)

    def __post_init__(self):
        for key in ("m", "l", "lc", "J"):
            object.__setattr__(self, key, _vec3(key, getattr(self, key)))
        object.__setattr__(self, "g", float(self.g))
        self.validate()

    def validate(self):
        for key in ("m", "l", "lc", "J"):
            if not np.all(np.isfinite(getattr(self, key))):
                raise PaaError(f"non-physical parameters: {key} = {getattr(self, key).tolist()} is not finite")
        for key in ("m", "l", "J"):
            values = getattr(self, key)
            bad = np.flatnonzero(values <= 0)
            if bad.size:
                i = bad[0]
                raise PaaError(f"non-physical parameters: {key}{i + 1} = {values[i]:g} must be > 0")
        for key, (low, high) in PLAUSIBLE.items():
            values = getattr(self, key)
            bad = np.flatnonzero((values < low) | (values > high))
            if bad.size:
                i = bad[0]
                raise PaaError(f"non-physical parameters: {key}{i + 1} = {values[i]:g} lies outside the plausible"
                               f" range [{low:g}, {high:g}]")
        bad = np.flatnonzero((self.lc < 0) | (self.lc > self.l))
        if bad.size:
            i = bad[0]
            raise PaaError(
                f"non-physical parameters: lc{i + 1} = {self.lc[i]:g} must lie in [0, l{i + 1}] = [0, {self.l[i]:g}]")
        if not (np.isfinite(self.g) and self.g > 0):
            raise PaaError(f"non-physical parameters: g = {self.g:g} must be > 0")

    @classmethod
    def uniform_rods(cls, m, l, g=9.81, name="custom"):
        """Slender uniform rods: lc = l / 2 and J = m l^2 / 12 (as Table 2 of the paper)."""
        m, l = _vec3("m", m), _vec3("l", l)
        return cls(m=m, l=l, lc=l / 2, J=m * l**2 / 12, g=g, name=name)

    def key(self) -> tuple:
        """The parameters as one hashable tuple (m, l, lc, J, g)."""
        return tuple(np.concatenate([self.m, self.l, self.lc, self.J, [self.g]]).tolist())

    def __eq__(self, other):
        return isinstance(other, RobotParams) and self.key() == other.key()

    def __hash__(self):
        return hash(self.key())

    def as_dict(self):
        return {"m": self.m.tolist(), "l": self.l.tolist(), "lc": self.lc.tolist(),
                "J": self.J.tolist(), "g": self.g}

    def scaled(self, mass_factor=1.0, length_factor=1.0):
        """Return a copy with masses (and inertias) and lengths scaled, for model-error studies.

        Inertias scale as m l^2, so a rod stays a rod.
        """
        return RobotParams(m=self.m * mass_factor, l=self.l * length_factor,
                           lc=self.lc * length_factor,
                           J=self.J * mass_factor * length_factor**2, g=self.g,
                           name=f"{self.name}*")
