"""Controllers behind one interface (:mod:`~paa_mj.control.base`), by name (:mod:`~paa_mj.control.registry`).

- :mod:`~paa_mj.control.energy`: swing-up (40) and the conventional candidate (12);
- :mod:`~paa_mj.control.lqr`: the LQR balance controller (67);
- :mod:`~paa_mj.control.combined`: the one-way switch, with region (68) as the paper's condition;
- :mod:`~paa_mj.control.region`: region (68) and the balance tolerance;
- :mod:`~paa_mj.control.gains`: the gains against the theory;
- :mod:`~paa_mj.control.passive`: zero torque.
"""
from .base import CompiledForm, Controller
from .combined import CombinedController, RegionCondition, TimeCondition
from .energy import ConventionalController, EnergyVCLController
from .gains import TheoryWarning, check_gains
from .lqr import LQRController
from .passive import PassiveController
from .region import BALANCE_TOL, SWITCH_ANGLE, SWITCH_SPEED, in_switch_region, switch_margin
from .registry import BUILTIN, ControllerSpec, make_controller

__all__ = ["BALANCE_TOL", "BUILTIN", "CombinedController", "CompiledForm", "Controller", "ControllerSpec",
           "ConventionalController", "EnergyVCLController", "LQRController", "PassiveController", "RegionCondition",
           "SWITCH_ANGLE", "SWITCH_SPEED", "TheoryWarning", "TimeCondition", "check_gains", "in_switch_region",
           "make_controller", "switch_margin"]
