"""The trajectory record of a rollout and its summary; saved as NPZ, CSV and JSON."""
from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..io import json_writer, npz_writer, write_set
from ..model.params import MAX_LINKS
from ..provenance import text_sha256
from ..task import Task
from .compiled.retirement import sampling_advice

FIELDS = ("t", "q", "qd", "tau", "E_minus_Er", "V", "mode")



def seconds_or_none(value):
    """A time [s] as a float, None where it is NaN (never happened)."""
    value = float(value)
    return None if np.isnan(value) else value


@dataclass
class Trajectory:
    """Samples of one rollout.

    Attributes
    ----------
    t : ndarray (n,)            time [s]
    q, qd : ndarray (n, 3)      joint angles [rad] (unwrapped) and speeds [rad/s]
    tau : ndarray (n, 2)        torques [N m] applied from t on (zero-order hold in MuJoCo)
    E_minus_Er : ndarray (n,)   E - E_r [J]
    V : ndarray (n,)            Lyapunov function (34) of controller (40) [J^2]
    mode : ndarray (n,) int8    0 swing-up (40), 1 balance (67)
    switch_time : float or None first switch to the balance controller [s]
    meta : dict                 robot, engine, integrator, time step, gains, x0, status
    robot_xml : str or None     MJCF text of the robot simulated (None: unknown, a file of an older version)
    task : Task or None         what the run aimed at and is judged by (None: the folded task)
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    E_minus_Er: np.ndarray
    V: np.ndarray
    mode: np.ndarray
    switch_time: float | None = None
    meta: dict = field(default_factory=dict)
    robot_xml: str | None = None
    task: Task | None = None

    def __post_init__(self):
        if self.task is None:
            self.task = Task.from_description(self.meta.get("task", self.meta.get("goal")), int(self.q.shape[-1]))

    def __len__(self):
        return len(self.t)

    @property
    def robot_sha256(self) -> str | None:
        """The fingerprint of the robot (:func:`text_sha256`), or None when the robot is unknown."""
        return None if self.robot_xml is None else text_sha256(self.robot_xml)

    @property
    def final_state(self):
        return np.concatenate([self.q[-1], self.qd[-1]])

    @property
    def n_links(self) -> int:
        return int(self.q.shape[-1])

    @property
    def driven_joints(self) -> list:
        """The joints (1-based) the torques' columns act on: the metadata's ``driven_joints``, else 2..n."""
        return list(self.meta.get("driven_joints", range(2, self.n_links + 1)))

    @property
    def goal(self) -> str:
        """The name of the goal the run aimed at."""
        return self.task.name

    def balanced(self) -> bool:
        """True when the final state is within the task's balance tolerance of its goal (angles mod 2 pi)."""
        return bool(len(self)) and bool(self.task.balanced(self.q[-1], self.qd[-1]))

    def outcome(self) -> str:
        """What became of the run, in one sentence from its own records (:func:`~paa_mj.sim.verdict.outcome_words`,
        every command's words), and what to try where the goal was not reached; with the torque limit named where
        the torques reached it."""
        from ..control.catalog import HANDS_OVER
        from .verdict import outcome_words

        controller = str(self.meta.get("controller", ""))
        return outcome_words(
            status=self.meta.get("status", ""), success=bool(self.meta.get("success", self.balanced())),
            balanced=self.balanced(), task=self.task, t_final=self.meta.get("t_final", 0.0),
            switch_time=self.switch_time, t_region=self._entered_region(),
            hands_over=controller in HANDS_OVER,
            final_state=self.final_state if len(self) else [], recent_speeds=self._recent_speeds(),
            saturated=self._saturation(),
            unstable=self._unstable_balance(), gains=bool(self.meta.get("gains")), engine=self.meta.get("engine"),
            region=str(self.meta.get("switch") or "").startswith("region"),
            idle=bool(len(self)) and not np.any(self.tau))

    def _recent_speeds(self):
        """The largest joint speed [rad/s] of each sample of the run's last second (None before a second)."""
        if not len(self) or self.t[-1] - self.t[0] < 1.0:
            return None
        return np.max(np.abs(self.qd[self.t >= self.t[-1] - 1.0]), axis=1)

    def _entered_region(self):
        """The first entry into region (68) [s] as the engine judged it at every step (``meta["t_region"]``), else
        as the recorded samples show it; None if never."""
        if "t_region" in self.meta:
            return self.meta["t_region"]
        inside = self.task.in_switch_region(self.q, self.qd) if len(self) else np.zeros(0, bool)
        return float(self.t[np.argmax(inside)]) if inside.any() else None

    def _unstable_balance(self) -> str:
        """Where the run switched to a balance that is unstable when sampled at its step: that, and what to do."""
        balance = self.meta.get("balance_sampling")
        if self.switch_time is None or not balance or balance["radius"] < 1.0:
            return ""
        return (f"; its balance (67) is unstable when sampled at dt = {self.meta['dt'] * 1e3:g} ms (spectral radius"
                f" {balance['radius']:.4g}), {sampling_advice(balance)}")

    def _saturation(self) -> str:
        limit = self.meta.get("torque_limit")
        peaks = self.meta.get("max_abs_tau")
        if limit is None or peaks is None:
            return ""
        hit = [j for j, p, lim in zip(self.driven_joints, peaks, limit) if np.isfinite(lim) and p >= lim * (1 - 1e-9)]
        return f", the torque of joint{'s' * (len(hit) > 1)} {', '.join(map(str, hit))} at its limit" if hit else ""

    def summary(self) -> dict:
        return {
            "outcome": self.outcome(),
            "switch_time": self.switch_time,
            "balanced": self.balanced(),
            "final_time": float(self.t[-1]) if len(self) else 0.0,
            "final_state": self.final_state.tolist() if len(self) else [],
            "E_minus_Er_final": float(self.E_minus_Er[-1]) if len(self) else None,
            "V_final": float(self.V[-1]) if len(self) else None,
            "max_abs_tau": np.max(np.abs(self.tau), axis=0).tolist() if len(self) else None,
            "samples": len(self),
            **self.meta,
            **self.task.describe(),
        }

    # --- files --------------------------------------------------------------------
    def save(self, out_dir, stem="trajectory"):
        """Write ``stem.npz``, ``stem.csv`` and ``summary.json`` into ``out_dir``, as one set (all or none).

        The NPZ also holds the robot's MJCF text and its sha256 when :attr:`robot_xml` is known, so
        that a replay draws the robot that was simulated, not another of the same name.
        """
        arrays = {name: getattr(self, name) for name in FIELDS}
        if self.robot_xml is not None:
            # bytes, not a NumPy string: UTF-32 would take four times the room
            arrays["robot_mjcf"] = np.frombuffer(self.robot_xml.encode("utf-8"), np.uint8)
            arrays["robot_sha256"] = np.asarray(self.robot_sha256)
        n = self.n_links
        header = ",".join(["t", *(f"q{i + 1}" for i in range(n)), *(f"d{i + 1}" for i in range(n)),
                           *(f"tau{j}" for j in self.driven_joints), "E_minus_Er", "V", "mode"])
        table = np.column_stack([self.t, self.q, self.qd, self.tau, self.E_minus_Er, self.V, self.mode])

        def csv(path):
            # 12 digits: a sample time of k dt is written as the step's time (6.25e-05, 0.03), never rounded to a
            # microsecond (steps of 62.5 us and less) nor shown as k dt's rounding (0.030000000000000002)
            np.savetxt(path, table, delimiter=",", header=header, comments="",
                       fmt=["%.12g"] + ["%.17g"] * (2 * n + self.tau.shape[1] + 2) + ["%d"])

        return write_set(out_dir, {
            f"{stem}.npz": npz_writer(**arrays, switch_time=np.nan if self.switch_time is None else self.switch_time,
                                      meta=json.dumps({**self.meta, "task": self.task.describe()["task"]})),
            f"{stem}.csv": csv,
            "summary.json": json_writer(self.summary()),
        })

    @classmethod
    def load(cls, path) -> "Trajectory":
        """Read a ``trajectory.npz`` written by :meth:`save`; one-line error when it is not one."""
        path = Path(path)
        if not path.exists():
            raise PaaError(f"trajectory file not found: {path}")
        if not path.is_file():
            raise PaaError(f"trajectory file is not a regular file: {path}")
        if not zipfile.is_zipfile(path):
            raise PaaError(f"corrupted or foreign trajectory file {path}: not an .npz archive (simulate --out writes"
                           " trajectory.npz)")
        try:
            with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
                arrays = {name: np.array(z[name]) for name in FIELDS}
                switch = float(z["switch_time"])
                meta = json.loads(str(z["meta"]))
                robot_xml, sha = None, None
                if "robot_sha256" in z.files or "robot_mjcf" in z.files:
                    robot_xml = np.asarray(z["robot_mjcf"], np.uint8).tobytes().decode("utf-8")
                    sha = str(z["robot_sha256"])
        except Exception as err:  # zipfile, KeyError, ValueError...: all mean "not our file"
            raise PaaError(f"corrupted or foreign trajectory file {path}: {type(err).__name__}: {' '.join(str(err).split())}") from None
        if not isinstance(meta, dict) or not isinstance(meta.get("robot", ""), str):
            raise PaaError(f"corrupted trajectory file {path}: its meta is not a JSON object naming its robot")
        for name, values in arrays.items():
            if values.dtype.kind not in "fiu":
                # complex numbers would lose their imaginary part in silence, text or objects fail later
                raise PaaError(f"corrupted trajectory file {path}: {name} holds {values.dtype} values, not real"
                               " numbers")
        n = len(arrays["t"])
        links = arrays["q"].shape[-1] if arrays["q"].ndim == 2 else 0
        if not 2 <= links <= MAX_LINKS:
            raise PaaError(f"corrupted trajectory file {path}: q has shape {arrays['q'].shape}, expected (samples,"
                           f" links) with 2 to {MAX_LINKS} links")
        shapes = {"q": (n, links), "qd": (n, links), "tau": (n, links - 1), "E_minus_Er": (n,), "V": (n,),
                  "mode": (n,)}
        for name, shape in shapes.items():
            if arrays[name].shape != shape:
                raise PaaError(f"corrupted trajectory file {path}: {name} has shape {arrays[name].shape}, expected {shape}")
        if n == 0 or not all(np.all(np.isfinite(arrays[k])) for k in ("t", "q", "qd")):
            raise PaaError(f"corrupted trajectory file {path}: empty or non-finite samples")
        if arrays["t"][0] < 0 or np.any(np.diff(arrays["t"]) <= 0):
            raise PaaError(f"corrupted trajectory file {path}: the times are not increasing from t >= 0")
        if np.any((arrays["mode"] != 0) & (arrays["mode"] != 1)):
            raise PaaError(f"corrupted trajectory file {path}: a controller mode is not 0 (swing-up) or 1 (balance)")
        arrays["mode"] = arrays["mode"].astype(np.int8)
        if robot_xml is not None and text_sha256(robot_xml) != sha:
            raise PaaError(f"corrupted trajectory file {path}: its robot's MJCF text does not match its sha256")
        try:
            return cls(**arrays, switch_time=None if np.isnan(switch) else switch, meta=meta, robot_xml=robot_xml)
        except PaaError as err:  # its task is not one
            raise PaaError(f"corrupted trajectory file {path}: {err}") from None
