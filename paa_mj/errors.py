"""The exceptions of the package, each a one-line message for the command line.

The CLI turns a :class:`PaaError` into one line on stderr and exit code 2, so a
user never sees a traceback for bad input; a :class:`SimulationDiverged` exits
with 3 after what was computed has been kept, a :class:`StudyIncomplete` with 4.
"""


class PaaError(Exception):
    """Bad input or a run that cannot go on; ``str(err)`` is the one-line message."""


class SimulationDiverged(PaaError):
    """The simulation left the finite world; what was computed so far is kept.

    Attributes
    ----------
    trajectory : paa_mj.sim.trajectory.Trajectory
        The samples recorded up to the last good state.
    """

    def __init__(self, message, trajectory=None):
        super().__init__(message)
        self.trajectory = trajectory


class StudyIncomplete(PaaError):
    """A study stopped before its end for a reason other than the user (lost workers); finished chunks are kept."""
