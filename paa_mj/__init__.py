"""paa_mj: the three-link gymnast of Liu & Xin (2015) on a high bar, in MuJoCo.

The package follows the system: the MJCF model (:mod:`paa_mj.model`) ->
parameters (:mod:`paa_mj.params`) -> analytic model (:mod:`paa_mj.dynamics`) and
theory (:mod:`paa_mj.theory`, :mod:`paa_mj.vcl`) -> controllers
(:mod:`paa_mj.controllers`) -> rollouts (:mod:`paa_mj.rollout`) -> outputs
(plots, video, reports); the command line (:mod:`paa_mj.cli`) sits on top.
"""
from .errors import PaaError, SimulationDiverged
from .params import RobotParams

__version__ = "0.1.0"
__all__ = ["PaaError", "SimulationDiverged", "RobotParams", "__version__"]
