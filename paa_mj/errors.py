"""One exception type for every user-facing failure.

The CLI turns a :class:`PaaError` into one line on stderr and exit code 2, so a
user never sees a traceback for bad input.
"""


class PaaError(Exception):
    """Bad input or a run that cannot go on; ``str(err)`` is the one-line message."""


class SimulationDiverged(PaaError):
    """The simulation left the finite world; what was computed so far is kept.

    Attributes
    ----------
    trajectory : paa_mj.rollout.Trajectory
        The samples recorded before the divergence.
    """

    def __init__(self, message, trajectory=None):
        super().__init__(message)
        self.trajectory = trajectory
