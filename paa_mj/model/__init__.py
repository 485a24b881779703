"""The robot: its MJCF file, its parameters and the paper's analytic model (1)-(7).

- :mod:`~paa_mj.model.mjcf`: the MJCF template; :mod:`~paa_mj.model.mjcf_read`: reading, validation, read-back;
- :mod:`~paa_mj.model.params`: :class:`RobotParams` (masses, lengths, inertias);
- :mod:`~paa_mj.model.equations`: M, H, G, P, E of (1)-(7), one definition for NumPy and numba;
- :mod:`~paa_mj.model.vcl`: the virtual composite link (13)-(21);
- :mod:`~paa_mj.model.dynamics`: :class:`AnalyticModel` on batches of states;
- :mod:`~paa_mj.model.robot`: :class:`Robot` and :func:`load_robot`;
- :mod:`~paa_mj.model.crosscheck`: MuJoCo against the analytic model.
"""
from ..lazy import lazy_exports

_EXPORTS = {
    "AnalyticModel": ".dynamics",
    "mjcf_from_params": ".mjcf",
    "params_from_model": ".mjcf_read",
    "RobotParams": ".params",
    "NAMED_ROBOTS": ".robot",
    "Robot": ".robot",
    "load_model": ".robot",
    "load_robot": ".robot",
    "model_from_params": ".robot",
    "robot_from_xml": ".robot",
    "robot_path": ".robot",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["AnalyticModel", "NAMED_ROBOTS", "Robot", "RobotParams", "load_model", "load_robot", "mjcf_from_params",
           "model_from_params", "params_from_model", "robot_from_xml", "robot_path"]
