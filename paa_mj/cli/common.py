"""Shared pieces of the command line: parent parsers, the parser class, output helpers, signals.

Every option says what it does, its default and its allowed values in
``--help``. Every failure the user can cause ends in one line on stderr.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import math
import re
import signal
import sys


from ..errors import PaaError

EXIT_BAD_INPUT, EXIT_DIVERGED, EXIT_INCOMPLETE = 2, 3, 4
#: How the options whose default is the task's horizon (Task.horizon) state it.
TASK_HORIZON = "the task's horizon, 30 s"
EXIT_SIGINT, EXIT_SIGTERM = 130, 143
_received = {"signal": None}


class Formatter(argparse.RawDescriptionHelpFormatter):
    """Help that shows each option's default (when it has one) after its text."""

    def _get_help_string(self, action):
        text = action.help or ""
        unset = action.default is None or action.default is False or action.default == argparse.SUPPRESS
        if "(default" in text or unset or not action.option_strings:  # a text that states its own default
            return text
        return text + " (default: %(default)s)"


#: What argparse must read as a negative number, not an option: its own pattern misses -1e-3, -1. and -inf.
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (a :class:`PaaError`), not usage text and exit 2.

    Negative numbers are values (``--x0 -1e-3 ...``, ``--torque-limit -1e3``), refused or used as such by
    the option's type, not unknown options ("expected one argument").
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", Formatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_NUMBER

    def error(self, message):
        raise PaaError(f"{message} (see '{self.prog} --help')")


def _ascii_number(text):
    """A one-line refusal of a number written otherwise than with ASCII characters, or None.

    Python's ``float`` and ``int`` read any Unicode digits (Arabic-Indic, full-width...) and
    underscores between digits: a command line that reads as something else than it runs.
    """
    if not text.isascii():
        return argparse.ArgumentTypeError(f"not a number: {text!r} (write numbers with the ASCII digits 0-9)")
    if "_" in text:
        return argparse.ArgumentTypeError(f"not a number: {text!r} (write numbers without underscores)")
    return None


def _whole_number(text):
    """An int written in ASCII decimal digits (optionally signed), else an ArgumentTypeError."""
    refused = _ascii_number(text)
    if refused is not None:
        raise refused
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None


def _number_type(accept, rule):
    """An argparse type: a float for which ``accept(value)`` holds, else '``rule``, got TEXT'."""
    def parse(text):
        refused = _ascii_number(text)
        if refused is not None:
            raise refused
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        if not (math.isfinite(value) and accept(value)):
            raise argparse.ArgumentTypeError(f"{rule}, got {text}")
        return value

    return parse


positive = _number_type(lambda v: v > 0, "must be a positive finite number")
non_negative = _number_type(lambda v: v >= 0, "must be a finite number >= 0")
finite = _number_type(lambda v: True, "must be finite")


def whole_number(text):
    """An argparse type: a whole number (any sign), in ASCII digits."""
    return _whole_number(text)


def positive_int(text):
    """An argparse type: a whole number >= 1, in ASCII digits."""
    value = _whole_number(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text}")
    return value


def links_count(text):
    """An argparse type: a number of links, 2..64 (:data:`paa_mj.model.params.MAX_LINKS`)."""
    value = _whole_number(text)
    if not 2 <= value <= 64:
        raise argparse.ArgumentTypeError(f"must be a whole number from 2 to 64, got {text}")
    return value


def folder(text):
    """An argparse type: an output folder, not empty."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no folder")
    return text


def file_path(text):
    """An argparse type: an output file, not empty and not ending in a separator (that names a folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file")
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(f"{text} names a folder; give a file name")
    return text


def seed(text):
    """An argparse type: a seed, a whole number in [0, 2^32) (:data:`paa_mj.limits.SEED_LIMIT`, the one range of every
    seed option)."""
    from ..limits import seed_refusal

    value = _whole_number(text)
    refused = seed_refusal(value, shown=text)
    if refused is not None:
        raise argparse.ArgumentTypeError(refused)
    return value


def search_budget(text):
    """An argparse type: CPU-seconds a search may take, positive and at most a day (what a command may work)."""
    from ..limits import MAX_SECONDS

    value = positive(text)
    if value > MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"{text} CPU-s is above {MAX_SECONDS:g} (a day), the longest a command may"
                                         " work")
    return value


#: What ``--kd-budget`` does, in every command that has it (the one option bounding the search of kD_min).
KD_BUDGET_HELP = ("CPU-seconds each certified search for kD_min (41) of a chain beyond the paper may take (default"
                  " 200, about a minute and a half on 2 cores; docs/model.md gives its cost by link count; kept on disk"
                  " for later commands): past it, or where a certificate is estimated at over 20 budgets, kD_min is a"
                  " certified bracket and the gains are taken above its upper end")


def search_parent(searches=""):
    """The option bounding every search a command may run: ``--kd-budget`` (``searches``: how many it runs)."""
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--kd-budget", type=search_budget, default=None, metavar="CPU_S",
                   help=KD_BUDGET_HELP + (f"; {searches}" if searches else ""))
    return p


#: The engines of ``--engine``: one vocabulary in every command, each name meaning the same wherever it is offered.
ENGINE_WORDS = {
    "cpu": "compiled rollouts on this machine's CPU cores (MuJoCo; for realaigym, their simulator)",
    "warp": "every rollout a world of a Warp device, the controller on the device too (pip install 'paa_mj[gpu]';"
            " the built-in controllers whose records declare a device law, every one but mpc; not a Python one)",
    "analytic": "the analytic model (1) by solve_ivp with continuous-time control",
}
#: Former spellings of the engines, still accepted: ``mujoco`` was the CPU engine's name in simulate and the studies.
ENGINE_ALIASES = {"mujoco": "cpu"}


def engine_option(parser, names, internal=None, extra=""):
    """Add ``--engine`` to ``parser``: the engines ``names`` of :data:`ENGINE_WORDS` (the first the default), read
    through :data:`ENGINE_ALIASES`; the command gets ``internal[name]`` (its own name for the engine) or the name."""
    internal = internal or {}

    def parse(text):
        name = ENGINE_ALIASES.get(text, text)
        if name not in names:
            raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from {', '.join(names)})")
        return internal.get(name, name)

    words = "; ".join(f"{name}: {ENGINE_WORDS[name]}" for name in names)
    aliases = ", ".join(f"{old}: the former name of {new}" for old, new in ENGINE_ALIASES.items() if new in names)
    parser.add_argument("--engine", type=parse, default=names[0], metavar="{" + ",".join(names) + "}",
                        help=f"{words}{extra}" + (f" ({aliases}, still accepted)" if aliases else "")
                        + f" (default: {names[0]})")


def robot_parent(default="gymnast", searches=True):
    p = argparse.ArgumentParser(add_help=False, parents=[search_parent()] if searches else [])
    p.add_argument("--robot", default=default, metavar="{gymnast,example2,acrobot,chain4,realaigym_acrobot,...,PATH.xml}",
                   help="gymnast (Table 1), example2 (Table 2), acrobot (Drake's), chain4 (four links),"
                        " realaigym_acrobot and realaigym_acrobot_v1 (RealAIGym's leaderboard acrobots),"
                        " realaigym_pendubot (their pendubot: the motor at the shoulder) or the MJCF"
                        " file of any planar chain on the bar"
                        + ("" if default else " (default: gymnast, or the trajectory's robot with --from)"))
    return p


def goal_parent():
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--goal", choices=("folded", "stretched"), default="folded",
                   help="the task: folded (the paper's UDD: link 1 up, the others down; for an acrobot the up-down"
                        " point) or stretched (every link up)")
    return p


def task_from_args(args, robot):
    """The :class:`~paa_mj.task.Task` that ``--goal`` names for ``robot``: the one place the command line makes a
    task, which every layer below is handed."""
    from ..task import Task

    task = Task.named(getattr(args, "goal", "folded"), robot)
    if getattr(args, "t_final", None) is not None:  # the run's length is the task's horizon, and stated as such
        from ..sim.inputs import check_whole_steps

        # every engine ends at the step nearest the time asked and judges there: the time asked must be one (a
        # time too long to count is the command's own refusal, which says what it would need)
        step = getattr(args, "dt", None) or float(robot.model.opt.timestep)
        if args.t_final / step < 1e15:
            check_whole_steps(args.t_final, step)
        return task.with_(horizon=args.t_final)
    if hasattr(args, "t_final"):  # an option whose default is the task's horizon
        args.t_final = task.horizon
    return task


def initial_state(args, robot, task):
    """--x0 checked against the robot (2n numbers), or the task's start; a one-line error otherwise."""
    from ..sim.inputs import check_initial_state

    n = robot.params.n_links
    if args.x0 is None:
        return task.start.copy()
    if len(args.x0) != 2 * n:
        names = " ".join([f"q{i + 1}" for i in range(n)] + [f"d{i + 1}" for i in range(n)])
        raise PaaError(f"--x0 needs {2 * n} numbers for robot {robot.name} ({names}), got {len(args.x0)}")
    return check_initial_state(args.x0, n)[0]


def gains_parent(stored="the robot's stored gains where kD is above (41) for the goal, else the family rule's"):
    p = argparse.ArgumentParser(add_help=False)
    shown = stored.replace("%", "%%")  # argparse formats help with %
    p.add_argument("--kD", type=positive, help=f"gain kD of (40)/(12) [J kg m^2] (default: {shown})")
    p.add_argument("--kP", type=positive, help="gain kP of (40)/(12) [J^2/rad^2] (default: as --kD)")
    p.add_argument("--kV", type=positive, help="gain kV of (40)/(12) [J^2 s/rad^2] (default: as --kD)")
    return p


def controller_parent():
    from ..control.catalog import DESCRIPTIONS

    p = argparse.ArgumentParser(add_help=False, parents=[gains_parent()])
    p.add_argument("--controller", default="vcl", metavar="{" + ",".join(DESCRIPTIONS) + ",FILE.py:Class}",
                   help="a built-in controller (" + "; ".join(f"{k}: {v}" for k, v in DESCRIPTIONS.items())
                   + ") or your own class in a Python file")
    p.add_argument("--kip-duration", type=positive, metavar="T",
                   help="duration of the trajopt-effort kip [s] (default 3); the first guess of trajopt's")
    p.add_argument("--plan-budget", type=positive, metavar="CPU_S",
                   help="CPU-seconds the trajectory optimisation of trajopt and trajopt-effort may take (default 600);"
                        " a plan not found within them is refused in one line")
    p.add_argument("--lqr-weights", type=positive, nargs=2, metavar=("Q", "R"),
                   help="weights of the balance LQR (67): Q = Q I on the state error, R = R I on the torques"
                        " (default the paper's 1e4 and 1; for vcl, vc, lqr, trajopt, trajopt-effort)")
    p.add_argument("--switch", choices=("region", "roa"),
                   help="where vcl and vc hand over to the LQR (67): region (68) (the default), or roa, the LQR's"
                        " cost-to-go below the level of its region of attraction with the run's torque limits (the model's"
                        " actuator ranges and --torque-limit, as paa-mj roa)")
    return p


def physics_parent():
    from ..sim.integrator_names import INTEGRATOR_NAMES

    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--t-final", type=positive, help=f"duration [s] (default: {TASK_HORIZON})")
    p.add_argument("--dt", type=positive, help="physics time step [s] (default: the model's, 0.001)")
    p.add_argument("--integrator", choices=INTEGRATOR_NAMES, help="MuJoCo integrator (default: the model's, RK4)")
    p.add_argument("--torque-limit", type=positive, metavar="T",
                   help="saturate each torque at T [N m] (the model's actuator ranges also apply)")
    return p


def check_fresh(args):
    """--fresh forgets what a study keeps in --out: without --out it is a contradiction, said in one line."""
    if args.fresh and not args.out:
        raise PaaError("--fresh forgets the chunks kept in --out; without --out nothing is kept")


def output_parent(what):
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--out", type=folder, metavar="DIR", help=f"folder for {what}")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object on stdout")
    return p


def study_parent():
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--scheduler", metavar="{inline,local,tcp://HOST:PORT}",
                   help="where chunks run: inline (this process), local (a local Dask cluster; the default when"
                        " Dask is installed) or a Dask scheduler address")
    p.add_argument("--chunk", type=positive_int, default=128,
                   help="rollouts per chunk: the unit of work sent to a worker and kept on disk")
    p.add_argument("--fresh", action="store_true",
                   help="start over: forget the finished chunks kept in --out, and replace another study's results"
                        " there (default: resume from them; a folder holding another study's is refused)")
    return p


def spec_from_args(args, robot, task, name=None):
    """The :class:`~paa_mj.control.registry.ControllerSpec` the controller options describe for ``robot`` and
    ``task``.

    Gains given on the command line replace the robot's stored ones, the others stay.
    """
    from ..control.catalog import GAIN_CONTROLLERS, LQR_CONTROLLERS, PLANNERS, SWITCHED, takes_run_limit
    from ..control.gains import resolve_gains
    from ..control.registry import ControllerSpec

    name = name or args.controller
    if getattr(args, "no_switch", False):
        if name not in ("vcl", "vcl-only"):
            raise PaaError(f"--no-switch means --controller vcl-only; it contradicts --controller {name}")
        name = "vcl-only"
    options = []
    if name in PLANNERS:
        if getattr(args, "torque_limit", None) is not None:
            options.append(("limit", (args.torque_limit,) * len(robot.torque_limits)))
        elif not all(math.isfinite(limit) for limit in robot.torque_limits):
            from ..sim.batch import kip_peak_torques

            options.append(("limit", tuple(kip_peak_torques(robot, ControllerSpec("vcl", task=task), task)
                                           .tolist())))
        if getattr(args, "kip_duration", None) is not None:
            options.append(("duration", args.kip_duration))
        if getattr(args, "plan_budget", None) is not None:
            options.append(("budget", args.plan_budget))
    else:
        for option, given in (("--kip-duration", "kip_duration"), ("--plan-budget", "plan_budget")):
            if getattr(args, given, None) is not None:
                raise PaaError(f"{option} applies to the controllers {', '.join(PLANNERS)}, not to {name}")
    weights = getattr(args, "lqr_weights", None)
    if weights is not None:
        if name not in LQR_CONTROLLERS:
            raise PaaError(f"--lqr-weights applies to the controllers {', '.join(LQR_CONTROLLERS)}, not to {name}")
        options.append(("lqr_weights", tuple(weights)))
    switch = getattr(args, "switch", None)
    if switch is not None:
        if name not in SWITCHED:
            raise PaaError(f"--switch applies to the controllers {', '.join(SWITCHED)}, not to {name}")
        if switch != "region":  # region (68) is the default hand-over: the spec stays the plain one
            options.append(("switch", switch))
    if getattr(args, "torque_limit", None) is not None and name not in PLANNERS and takes_run_limit(name, switch):
        options.append(("limit", (args.torque_limit,) * len(robot.torque_limits)))  # planned within, or the level
    given = {k: getattr(args, k, None) for k in ("kD", "kP", "kV")}
    if all(v is None for v in given.values()):
        return ControllerSpec(name, options=tuple(options), task=task)
    if name not in GAIN_CONTROLLERS:
        raise PaaError(f"--kD, --kP and --kV apply to the controllers {', '.join(GAIN_CONTROLLERS)}, not to {name}")
    return ControllerSpec(name, tuple(resolve_gains(robot, task, **given).values()), options=tuple(options),
                          task=task)


_json_stdout = None


@contextlib.contextmanager
def json_only_on_stdout():
    """Standard output kept for the JSON object: anything else printed meanwhile (a user's
    controller, say) goes to stderr, so that ``--json`` output stays one parseable object."""
    global _json_stdout
    _json_stdout, sys.stdout = sys.stdout, sys.stderr
    try:
        yield
    finally:
        sys.stdout, _json_stdout = _json_stdout, None


def print_json(obj):
    from ..io import dumps

    print(dumps(obj), file=_json_stdout or sys.stdout)


def note(message):
    """One line on stderr, prefixed like every message of the command."""
    print(f"paa-mj: {message}", file=sys.stderr)


def diverged_note(diverged, runs, what="runs"):
    """The one way a study says how many of its finished ``runs`` diverged (``simulate`` and a protocol's single run
    exit 3 instead): one line on stderr, nothing where none did."""
    if diverged:
        note(f"{diverged} of {runs} {what} diverged (non-finite, or joint speeds above the engines' limit), each counted"
             " a failure")


def interrupt_code() -> int:
    """130 after Ctrl-C, 143 after SIGTERM."""
    return EXIT_SIGTERM if _received["signal"] == signal.SIGTERM else EXIT_SIGINT


def interrupt_name() -> str:
    return "terminated (SIGTERM)" if _received["signal"] == signal.SIGTERM else "interrupted"


def finish(interrupted, what, out=None, kept="finished chunks are kept in {out}, run the same command to resume"):
    """0, or after an interruption one line on stderr (what was done, where it is kept) and 130/143."""
    if not interrupted:
        return 0
    note(f"{interrupt_name()}: {what}" + (f"; {kept.format(out=out)}" if out else ""))
    return interrupt_code()


def install_signal_handlers():
    """SIGTERM is handled like Ctrl-C (finished work is kept), and remembered for the exit code."""
    def on_term(signum, frame):
        _received["signal"] = signum
        raise KeyboardInterrupt

    _received["signal"] = None
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal.signal(signal.SIGTERM, on_term)
    except ValueError:  # not the main thread
        return None
    return previous
