"""Controllers behind one interface (:mod:`~paa_mj.control.base`), by name (:mod:`~paa_mj.control.registry`).

Each built-in controller is declared once, beside its law, by a record (:mod:`~paa_mj.control.record`) that the
catalog (:mod:`~paa_mj.control.catalog`), the registry, the engines, the studies and the tests derive from:

- :mod:`~paa_mj.control.energy`: swing-up (40) and the conventional candidate (12);
- :mod:`~paa_mj.control.lqr`: the LQR balance controller (67);
- :mod:`~paa_mj.control.combined`: the one-way switch, with region (68) of the task as the paper's condition;
- :mod:`~paa_mj.control.region`: the switch (68) compiled, and a candidate reading of the paper's;
- :mod:`~paa_mj.control.gains`: the gains, their one owner: stored, by rule, given, checked against the theory;
- :mod:`~paa_mj.control.tvlqr`, :mod:`~paa_mj.control.trajopt`: the planned kips, tracked;
- :mod:`~paa_mj.control.passive`: zero torque;
- :mod:`~paa_mj.control.spong`: Spong's acrobot swing-up as Drake states it.

Every controller is built for a robot and a :class:`~paa_mj.task.Task` and bound to both
(:class:`~paa_mj.control.base.Binding`).
"""
from ..lazy import lazy_exports

_EXPORTS = {
    "Binding": ".base",
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
    "BUILTIN": ".registry",
    "ControllerSpec": ".registry",
    "make_controller": ".registry",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["BUILTIN", "Binding", "CombinedController", "CompiledForm", "Controller", "ControllerSpec",
           "ConventionalController", "EnergyVCLController", "LQRController", "PassiveController", "RegionCondition",
           "SpongController", "TheoryWarning", "TimeCondition", "check_gains", "make_controller"]
