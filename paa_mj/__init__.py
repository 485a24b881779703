"""paa_mj: the three-link gymnast of Liu & Xin (2015) on a high bar, in MuJoCo.

The package follows the system:

- :mod:`paa_mj.model`: the MJCF model, its parameters and the paper's analytic model (1)-(7);
- :mod:`paa_mj.theory`: the conditions of Theorem 1, the linear analysis at UDD;
- :mod:`paa_mj.control`: one controller interface, the controllers (40), (12), (67), the switch (68);
- :mod:`paa_mj.sim`: rollouts in MuJoCo (single and batch, compiled) and of the analytic model;
- :mod:`paa_mj.studies`: basins, robustness, benchmarks, on Dask;
- :mod:`paa_mj.outputs`: plots, video, the reproduction report;
- :mod:`paa_mj.cli`: the ``paa-mj`` command line, a thin layer on top.
"""
from .errors import PaaError, SimulationDiverged
from .provenance import key_numba_cache_by_code

key_numba_cache_by_code()

__version__ = "0.17.0"
__all__ = ["PaaError", "SimulationDiverged", "__version__"]
