"""Controllers behind one interface (:mod:`~paa_mj.control.base`), by name (:mod:`~paa_mj.control.registry`).

- :mod:`~paa_mj.control.energy`: swing-up (40) and the conventional candidate (12);
- :mod:`~paa_mj.control.lqr`: the LQR balance controller (67);
- :mod:`~paa_mj.control.combined`: the one-way switch, with region (68) as the paper's condition;
- :mod:`~paa_mj.control.region`: region (68) and the balance tolerance;
- :mod:`~paa_mj.control.gains`: the gains against the theory;
- :mod:`~paa_mj.control.passive`: zero torque;
- :mod:`~paa_mj.control.spong`: Spong's acrobot swing-up as Drake states it.
"""
from ..lazy import lazy_exports

_EXPORTS = {
    "CompiledForm": ".base",
    "Controller": ".base",
    "CombinedController": ".combined",
    "RegionCondition": ".combined",
    "TimeCondition": ".combined",
    "ConventionalController": ".energy",
    "EnergyVCLController": ".energy",
    "TheoryWarning": ".gains",
    "check_gains": ".gains",
    "LQRController": ".lqr",
    "PassiveController": ".passive",
    "SpongController": ".spong",
    "BALANCE_TOL": ".region",
    "SWITCH_ANGLE": ".region",
    "SWITCH_SPEED": ".region",
    "in_switch_region": ".region",
    "switch_margin": ".region",
    "BUILTIN": ".registry",
    "ControllerSpec": ".registry",
    "make_controller": ".registry",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["BALANCE_TOL", "BUILTIN", "CombinedController", "CompiledForm", "Controller", "ControllerSpec",
           "ConventionalController", "EnergyVCLController", "LQRController", "PassiveController", "RegionCondition",
           "SWITCH_ANGLE", "SpongController", "SWITCH_SPEED", "TheoryWarning", "TimeCondition", "check_gains", "in_switch_region",
           "make_controller", "switch_margin"]
