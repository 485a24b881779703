"""The ``paa-mj`` command line: a thin layer over the package.

Every failure the user can cause ends in one line on stderr: exit code 2 for
bad input, 3 for a simulation that diverged (what was computed is kept), 4 for
a study that lost its workers (finished chunks are kept), 130 after Ctrl-C and
143 after SIGTERM (finished work is kept).
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import os
import signal
import sys
import warnings

from ..errors import PaaError, SimulationDiverged, StudyIncomplete
from .common import EXIT_BAD_INPUT, EXIT_DIVERGED, EXIT_INCOMPLETE, Parser, install_signal_handlers, interrupt_code, \
    interrupt_name, json_only_on_stdout, note

DESCRIPTION = """\
The three-link gymnast of Liu & Xin (2015) on a high bar, in MuJoCo: the model,
the paper's theory, its controllers and yours, rollouts, studies, figures, video.
Run 'paa-mj COMMAND --help' for the options of a command."""


@functools.lru_cache(maxsize=1)
def build_parser():
    """The command line's parser, built once per process (argparse keeps nothing of a parse in it)."""
    from .. import __version__
    from . import peers, realaigym, reproduce, roa, simulate, studies, theory

    parser = Parser(prog="paa-mj", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"paa-mj {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    for module in (theory, roa, simulate, studies, reproduce, peers, realaigym):
        module.register(sub, Parser)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None):
    from ..control.gains import GainsNote

    print(f"paa-mj: {'note' if issubclass(category, GainsNote) else 'warning'}: {message}", file=sys.stderr)


def _choose_gl_early(argv):
    """Honour ``--gl egl|osmesa`` before anything imports MuJoCo (which reads MUJOCO_GL once, on import)."""
    args = list(sys.argv[1:] if argv is None else argv)
    value = None
    for i, arg in enumerate(args):
        if arg == "--gl" and i + 1 < len(args):
            value = args[i + 1]
        elif arg.startswith("--gl="):
            value = arg.split("=", 1)[1]
    if value in ("egl", "osmesa") and "mujoco" not in sys.modules:
        os.environ["MUJOCO_GL"] = os.environ["PYOPENGL_PLATFORM"] = value


def _check_environment():
    """Refuse, in one line, the environment variables that would make importing MuJoCo or numba fail.

    Both libraries read them once, on import, and fail there with a traceback (``MUJOCO_GL=invalid``,
    ``NUMBA_NUM_THREADS=0``) or print one inside a warning (``NUMBA_NUM_THREADS=abc``); uncompiled
    (``NUMBA_DISABLE_JIT``) the physics would not move.
    """
    from ..provenance import numba_cache_folder, require_compiled_kernels
    from ..view.gl import check_mujoco_gl

    check_mujoco_gl()
    require_compiled_kernels()
    numba_cache_folder()  # a writable folder for the compiled kernels, or one line saying what to set
    threads = os.environ.get("NUMBA_NUM_THREADS")
    if threads is not None:
        try:
            count = int(threads)  # as numba reads it
        except ValueError:
            count = None
        if count is None or count < 1:
            raise PaaError(f"the environment variable NUMBA_NUM_THREADS={threads!r} must be a whole number >= 1"
                           " (the threads of compiled code), or unset")


def _load_libraries():
    """Import MuJoCo and numba (through the package), any failure of theirs as one line."""
    try:
        import mujoco  # noqa: F401
        import numba  # noqa: F401
    except PaaError:
        raise
    except Exception as err:  # a broken installation fails in many ways; each says why in its message
        raise PaaError(f"cannot load MuJoCo or numba: {type(err).__name__}: {' '.join(str(err).split())}") from None


@contextlib.contextmanager
def _said_when_compiling():
    """One line on stderr when the block first compiles a kernel (a fresh install or update: numba's cache had none
    of it), none when it only loads them or needs none (a refusal stays one line)."""
    from numba.core import event

    from ..progress import stage
    from ..provenance import numba_cache_folder

    class FirstCompilation(event.Listener):
        said = False

        def on_start(self, event_):
            if not self.said:
                self.said = True
                stage(f"paa-mj: compiling the kernels this command needs, kept in {numba_cache_folder()} for later runs"
                      " (once per install or update; paa-mj compile compiles them all beforehand)")

        def on_end(self, event_):
            pass

    listener = FirstCompilation()
    event.register("numba:compile", listener)
    try:
        yield
    finally:
        event.unregister("numba:compile", listener)


def _drop_stdout():
    """Standard output to /dev/null, so that nothing more is written where writing failed."""
    with contextlib.suppress(OSError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())


def main(argv=None):
    if sys.stdout is None:  # started with standard output closed (>&-): what it would print goes nowhere
        sys.stdout = open(os.devnull, "w")
    _choose_gl_early(argv)
    previous = install_signal_handlers()
    try:
        try:  # before MuJoCo, numba and SciPy load: --help and --version answer at once
            args = build_parser().parse_args(argv)
        except SystemExit as exit_:  # --help and --version
            return exit_.code or 0
        _check_environment()
        _load_libraries()
        from ..mujoco_log import mujoco_log_off
        from ..progress import stage, watchdog

        with warnings.catch_warnings(), mujoco_log_off():
            warnings.showwarning = _show_warning
            from ..control.gains import GainsNote, TheoryWarning
            from ..sim.compiled.retirement import SamplingWarning

            warnings.simplefilter("always", TheoryWarning)
            warnings.simplefilter("always", SamplingWarning)  # said once per robot, goal, step and gain by itself
            warnings.simplefilter("always", GainsNote)  # said once per robot and goal by the note itself
            quiet = getattr(args, "json", False)
            # --json keeps stdout for the object and stderr for its silences: a long run still says it works
            from ..theory.kd_search import search_budget

            with json_only_on_stdout() if quiet else contextlib.nullcontext(), watchdog(f"paa-mj {args.command}"), \
                    search_budget(getattr(args, "kd_budget", None)):
                with contextlib.nullcontext() if quiet else _said_when_compiling():
                    code = args.func(args)
            sys.stdout.flush()  # a write that fails (a full disk) fails here, where it is reported
            return code
    except SimulationDiverged as err:
        note(f"error: {err}")
        return EXIT_DIVERGED
    except StudyIncomplete as err:
        note(f"error: {err}")
        return EXIT_INCOMPLETE
    except PaaError as err:
        note(f"error: {err}")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        note(interrupt_name())
        return interrupt_code()
    except ctypes.ArgumentError as err:
        # Ctrl-C or SIGTERM while ctypes converts the arguments of a C call (EGL's, say) comes as this error
        if "KeyboardInterrupt" not in str(err):
            raise
        note(interrupt_name())
        return interrupt_code()
    except BrokenPipeError:
        # The reader went away (paa-mj theory | head -1): end quietly, as a command in a pipe does.
        _drop_stdout()
        return 128 + signal.SIGPIPE
    except OSError as err:  # files are written through paa_mj.io, so this is standard output
        _drop_stdout()
        note(f"error: cannot write the output: {err.strerror or err}")
        return EXIT_BAD_INPUT
    except MemoryError:
        note("error: out of memory: lower the size of the request")
        return EXIT_BAD_INPUT
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
