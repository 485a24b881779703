"""RealAIGym's benchmark protocols, as their code computes them, in one place.

- :mod:`~paa_mj.realaigym.simulator`: their simulator (their acrobot's RK4, motor and disturbances), compiled for
  the CPU; :mod:`~paa_mj.realaigym.simulator_warp`: the same on a Warp device;
- :mod:`~paa_mj.realaigym.scores`: their scores (the RealAI score v2, robustness, the global test);
- :mod:`~paa_mj.realaigym.study`: the protocols run for a controller (``paa-mj realaigym``), kept and resumed;
- :mod:`~paa_mj.realaigym.outputs`: its files and charts;
- :mod:`~paa_mj.realaigym.bench`: its row of ``paa-mj bench``.

The command line (:mod:`paa_mj.cli.realaigym`) is a thin layer over :func:`~paa_mj.realaigym.study.run_protocol`
and :func:`~paa_mj.realaigym.outputs.write_realaigym`.
"""
from ..lazy import lazy_exports

_EXPORTS = {"run_protocol": ".study", "write_realaigym": ".outputs"}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["run_protocol", "write_realaigym"]
