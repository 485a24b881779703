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
from .compiled.step import NONFINITE_TORQUE, STATUS_TEXT

FIELDS = ("t", "q", "qd", "tau", "E_minus_Er", "V", "mode")



def _try(remedies) -> str:
    """"; try a, b or c" (nothing without a remedy)."""
    if not remedies:
        return ""
    return "; try " + (", ".join(remedies[:-1]) + " or " if len(remedies) > 1 else "") + remedies[-1]


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
    def goal(self) -> str:
        """The name of the goal the run aimed at."""
        return self.task.name

    def balanced(self) -> bool:
        """True when the final state is within the task's balance tolerance of its goal (angles mod 2 pi)."""
        return bool(len(self)) and bool(self.task.balanced(self.q[-1], self.qd[-1]))

    def outcome(self) -> str:
        """What became of the run, in one sentence, and what to try where the goal was not reached: diverged (when,
        and after which switch), never entered region (68), entered it without switching, switched without
        balancing; with the torque limit named where the torques reached it."""
        status = self.meta.get("status", "")
        switched = "" if self.switch_time is None else f" after switching to (67) at t = {self.switch_time:.4f} s"
        saturated = self._saturation()
        # a balance that cannot hold at this step is the reason, and its remedy replaces the generic ones
        unstable = self._unstable_balance()
        # remedies only where they apply: gains to a gain controller, --dt to MuJoCo, --switch to (68)'s hand-over
        gains, region = bool(self.meta.get("gains")), str(self.meta.get("switch") or "").startswith("region")
        if status.startswith("diverged"):
            # a torque of NaN or inf is the law's own doing: no time step mends it
            law = STATUS_TEXT[NONFINITE_TORQUE] in status
            remedies = ["gains with a larger margin over kD_min (41) (paa-mj theory shows the family rule's)"] * gains \
                + ["a smaller --dt"] * (self.meta.get("engine") != "analytic" and not law) \
                + ["--switch roa"] * (region and not law) + ["a controller whose torque is finite at every state"] * (
                    law and not gains)
            return f"{status}{switched}{saturated}" + (unstable or _try(remedies))
        if status.startswith("interrupted"):  # what it had done by then: no verdict on the whole run
            where = f"at the {self.goal} goal" if self.balanced() else f"not at the {self.goal} goal"
            return (f"{status}, before the end of its {self.meta.get('t_final', 0.0):g} s, {where}{switched}"
                    f"{saturated}; run it whole for its outcome")
        if self.meta.get("success", self.balanced()):
            return f"reached the {self.goal} goal and held it (the task's success){switched}{saturated}"
        longer = ["a longer --t-final"] + ["other gains (paa-mj gain-search compares rules of gains)"] * gains
        if self.switch_time is None:
            entered = self._entered_region()
            if entered is None:
                return (f"never entered region (68) in {self.meta.get('t_final', 0.0):g} s{saturated}{_try(longer)}")
            return f"entered region (68) at t = {entered:.4f} s but never handed over to (67){saturated}"
        return f"not balanced at the {self.goal} goal at the end{switched}{saturated}" + (
            unstable or _try(["--switch roa (a certified hand-over)"] * region + ["a longer --t-final"]))

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
        hit = [i + 2 for i, (p, lim) in enumerate(zip(peaks, limit)) if np.isfinite(lim) and p >= lim * (1 - 1e-9)]
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
                           *(f"tau{i + 2}" for i in range(n - 1)), "E_minus_Er", "V", "mode"])
        table = np.column_stack([self.t, self.q, self.qd, self.tau, self.E_minus_Er, self.V, self.mode])

        def csv(path):
            # 12 digits: a sample time of k dt is written as the step's time (6.25e-05, 0.03), never rounded to a
            # microsecond (steps of 62.5 us and less) nor shown as k dt's rounding (0.030000000000000002)
            np.savetxt(path, table, delimiter=",", header=header, comments="",
                       fmt=["%.12g"] + ["%.17g"] * (3 * n + 1) + ["%d"])

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
