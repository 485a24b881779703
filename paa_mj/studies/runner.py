"""Running a study's rollouts in fixed chunks: in this process or on Dask, resumably.

A study is a :class:`RolloutSet` (one entry per rollout: initial state,
controller recipe, plant, disturbances). It is cut into chunks of ``CHUNK``
rollouts, always the same way; a chunk is one call of
:func:`paa_mj.sim.batch.simulate_batch`, and every rollout keeps its global
number, which alone (with the seed) fixes its noise. So the results are
identical whichever way the chunks run: inline, on a local Dask cluster (the
default when Dask is installed), or on any cluster given by its scheduler
address. Workers rebuild the robot from its MJCF text and the controllers from
their recipes, so a remote cluster needs no files of ours (a user's controller
file must be readable there at the same path).

Finished chunks go to a :class:`~paa_mj.studies.store.ChunkStore` as they
finish. Ctrl-C or SIGTERM stops cleanly and keeps them; so does the loss of
every Dask worker (:class:`~paa_mj.errors.StudyIncomplete`). The same command
run again resumes.
"""
from __future__ import annotations

import contextlib
import logging
import signal
import sys
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..control.registry import ControllerSpec
from ..errors import PaaError, StudyIncomplete
from ..progress import progress as progress_bar
from ..limits import check_memory, check_steps
from ..model.robot import Robot, robot_from_xml
from ..sim.batch import OUTCOMES, BatchResult, Disturbances, check_engine, simulate_batch
from ..task import Task
from .store import ChunkStore, check_arrays

CHUNK = 128
SCHEDULERS = ("inline", "local")


def dask_available() -> bool:
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def check_scheduler(value) -> str:
    """``inline``, ``local`` or a Dask address (default: local when Dask is installed)."""
    if value is None:
        return "local" if dask_available() else "inline"
    if value not in SCHEDULERS and "://" not in value:
        raise PaaError(f"--scheduler must be inline, local or an address like tcp://host:8786, got {value!r}")
    if "://" in value:
        scheme = value.split("://", 1)[0]
        if scheme != "tcp":
            raise PaaError(f"--scheduler {value}: only tcp:// scheduler addresses are supported ({scheme}:// would"
                           " need that transport's own security or network set-up)")
        probe_scheduler(value)  # before any work: an address that is no scheduler fails within seconds
    if value != "inline" and not dask_available():
        raise PaaError("Dask is not installed: pip install 'paa_mj[dask]' (or use --scheduler inline)")
    return value


def _host_port(address):
    host, _, port = address.split("://", 1)[1].rpartition(":")
    host = host.strip("[]")
    if not host or not port.isascii() or not port.isdigit() or not 0 < int(port) < 65536:
        raise PaaError(f"--scheduler {address}: give tcp://HOST:PORT with a port in 1..65535")
    return host, int(port)


#: Seconds to wait for a scheduler's first bytes.
PROBE_TIMEOUT = 5.0


def probe_scheduler(address, timeout=PROBE_TIMEOUT):
    """Check that a Dask scheduler answers at ``address`` before handing it to Dask (one-line errors).

    A Dask scheduler greets every new connection with its handshake, a message framed
    as (total length, number of frames, frame lengths...) in little-endian uint64s. A
    server of another kind (a web server says nothing until asked) or a peer sending
    anything else is refused within ``timeout`` seconds, instead of a hang or a
    misleading error from deep inside Dask.
    """
    import socket
    import struct

    host, port = _host_port(address)
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            sock.settimeout(timeout)
            data = b""
            while len(data) < 16:
                piece = sock.recv(16 - len(data))
                if not piece:
                    break
                data += piece
    except socket.timeout:
        raise PaaError(f"no Dask scheduler at {address}: something listens there but sent no Dask handshake within"
                       f" {timeout:g} s (a web server?)") from None
    except OSError as err:
        raise PaaError(f"cannot reach the Dask scheduler {address}: {err.strerror or err}") from None
    if len(data) < 16:
        raise PaaError(f"no Dask scheduler at {address}: the connection closed before a Dask handshake")
    total, frames = struct.unpack("<QQ", data)
    if not (1 <= frames <= 64 and 8 * (frames + 1) <= total <= 2**20):
        raise PaaError(f"no Dask scheduler at {address}: it answered with something that is not a Dask handshake")


class _StdoutToStderr:
    """A chunk task whose prints (a user controller's, on a Dask worker) go to stderr, never to our stdout."""

    def __init__(self, task):
        self.task = task

    def __call__(self, shared, payload):
        with contextlib.redirect_stdout(sys.stderr):
            return self.task(shared, payload)


@dataclass
class RolloutSet:
    """Every rollout of a study, one entry each (N of them).

    Attributes
    ----------
    x0 : ndarray (N, 2n)
    controllers : list of ControllerSpec (N)
    plants : list of RobotParams or None (N), or None for the nominal robot everywhere
    torque_limit : ndarray (N, n - 1) [N m], inf for none
    noise_std : ndarray (N, 2) on q [rad] and qd [rad/s]
    torque_noise : ndarray (N,) [N m]
    delay_steps : ndarray (N,) of int
    pushes : ndarray (N, K, 2 + n) or None
    noise_ids : ndarray (N,) of int, optional
        The number that keys each rollout's noise stream with the seed (default: its
        index); a study gives a rollout the same number whatever runs beside it.
    task : Task
        What every rollout aims at and is judged by (the controllers' specs are built for it).
    """

    x0: np.ndarray
    controllers: list
    task: Task
    plants: list | None = None
    torque_limit: np.ndarray | None = None
    noise_std: np.ndarray | None = None
    torque_noise: np.ndarray | None = None
    delay_steps: np.ndarray | None = None
    pushes: np.ndarray | None = None
    noise_ids: np.ndarray | None = None
    labels: dict = field(default_factory=dict)

    def __post_init__(self):
        n = len(self.x0)
        self.x0 = np.asarray(self.x0, dtype=float)
        motors = self.x0.shape[1] // 2 - 1 if self.x0.ndim == 2 else 2
        if not isinstance(self.task, Task):
            raise PaaError(f"a study's rollouts need their Task, got {type(self.task).__name__}")
        if isinstance(self.controllers, (str, ControllerSpec)):
            spec = ControllerSpec(self.controllers, task=self.task) if isinstance(self.controllers, str) \
                else self.controllers
            self.controllers = [spec] * n
        self.controllers = [spec.for_task(self.task) if isinstance(spec, ControllerSpec) and spec.task is None
                            else spec for spec in self.controllers]
        defaults = {"torque_limit": ((n, motors), np.inf), "noise_std": ((n, 2), 0.0), "torque_noise": ((n,), 0.0),
                    "delay_steps": ((n,), 0.0)}
        for name, (shape, value) in defaults.items():
            current = getattr(self, name)
            setattr(self, name, np.full(shape, value) if current is None else np.broadcast_to(
                np.asarray(current, dtype=float), shape).copy())
        self.noise_ids = np.arange(n, dtype=np.int64) if self.noise_ids is None else \
            np.asarray(self.noise_ids, dtype=np.int64).reshape(n)
        if len(self.controllers) != n or (self.plants is not None and len(self.plants) != n):
            raise PaaError("a study needs one controller (and plant) per rollout")

    def __len__(self):
        return len(self.x0)

    def chunk(self, start, stop) -> dict:
        """Keyword arguments of :func:`simulate_batch` for rollouts [start, stop)."""
        part = slice(start, stop)
        return {"x0": self.x0[part], "controller": self.controllers[part],
                "plants": None if self.plants is None else self.plants[part],
                "torque_limit": self.torque_limit[part], "task": self.task,
                "disturbances": Disturbances(self.noise_std[part], self.torque_noise[part], self.delay_steps[part],
                                             None if self.pushes is None else self.pushes[part],
                                             rollout_ids=self.noise_ids[part])}

    def definition(self) -> dict:
        """What identifies these rollouts (for the chunk store's key)."""
        plants = None if self.plants is None else [None if p is None else p.as_dict() for p in self.plants]
        # each distinct spec object described once: a study's rollouts share a few
        described = {key: _spec_dict(spec) for key, spec in {id(s): s for s in self.controllers}.items()}
        return {"x0": self.x0, "controllers": [described[id(s)] for s in self.controllers], "plants": plants,
                "torque_limit": np.where(np.isinf(self.torque_limit), -1.0, self.torque_limit),
                "noise_std": self.noise_std, "torque_noise": self.torque_noise, "delay_steps": self.delay_steps,
                "pushes": self.pushes, "noise_ids": self.noise_ids, **task_definition(self.task)}


def engine_definition(engine="mujoco") -> dict:
    """What identifies the engine in a study's key: nothing for MuJoCo (the keys of before), else its name."""
    return {} if engine == "mujoco" else {"engine": engine}


def task_definition(task: Task | None) -> dict:
    """What identifies a task in a study's key: nothing for the folded task's defaults, the goal's name for another
    goal's defaults, else every field (so that chunks judged by another task are never reused)."""
    if task is None or task == Task.named("folded", task.n_links):
        return {}
    if task == Task.named(task.name, task.n_links):
        return {"goal": task.name}
    return {"task": list(task.key())}


def _spec_dict(spec: ControllerSpec):
    return {"name": spec.name, "gains": spec.gains, "check": spec.check, "options": [list(o) for o in spec.options],
            "believed": None if spec.believed is None else spec.believed.as_dict(), "source": spec.source_digest(),
            **task_definition(spec.task)}


def applied_limit(robot, torque_limit):
    """The torque limits a study's runs get [N m]: ``torque_limit`` capped by the model's actuator ranges,
    as a list of one per motor, or None when neither limits."""
    limits = robot.capped_torque_limits(torque_limit)
    return None if np.all(np.isinf(limits)) else limits.tolist()


def peak_torques(max_abs_tau, completed):
    """The largest :math:`|\\tau_k|` of each motor applied over the finished runs [N m] (None if none finished)."""
    done = np.asarray(max_abs_tau)[np.asarray(completed, bool)]
    return np.max(done, axis=0).tolist() if len(done) else None


def _run_chunk(xml, name, kwargs, t_final, seed, nthread, retire, engine="mujoco", device=None, progress=False):
    from dataclasses import replace

    robot = robot_from_xml(xml, name=name)
    kwargs = dict(kwargs, disturbances=replace(kwargs["disturbances"], seed=seed))
    result = simulate_batch(robot, t_final=t_final, nthread=nthread, retire=retire, engine=engine, device=device,
                            progress=progress, partial=True, **kwargs)
    out = {key: getattr(result, key) for key in OUTCOMES}
    out["completed"] = result.meta["completed"]
    out["interrupted"] = result.interrupted  # read and dropped by map_chunks, never stored
    return out


def map_chunks(task, payloads, *, scheduler="inline", store=None, progress=False, desc="chunks", is_complete=None,
               shared=None, fits=None):
    """Run ``task(shared, payload)`` for every payload, in this process or on Dask, keeping each result in ``store``.

    Results already in ``store`` are not computed again when they fit their payload
    (``fits(payload, result)``: the names and shapes of the arrays, and what identifies
    the payload) and are complete (``is_complete``); a kept result that does not fit is
    computed again, and a line on stderr says so. Each new one is saved as it arrives.
    ``shared`` is sent to each Dask worker once.

    Returns
    -------
    (dict index -> result, interrupted)
        The finished results; ``interrupted`` after Ctrl-C, SIGTERM or a result that
        ``is_complete`` refuses (the task saw the interrupt itself).

    Raises
    ------
    StudyIncomplete
        Every Dask worker was lost; the finished results are kept in ``store``.
    """
    scheduler = check_scheduler(scheduler)
    store = store or ChunkStore(None, "")
    is_complete = is_complete or (lambda result: True)
    fits = fits or (lambda payload, result: True)
    finished, misfits = {}, 0
    for index in range(len(payloads)):
        kept = store.load(index)
        if kept is None:
            continue
        if fits(payloads[index], kept) and is_complete(kept):
            finished[index] = kept
        else:
            misfits += 1
    if misfits:
        print(f"note: {misfits} kept chunk(s) in {store.path} did not fit this study (damaged or from other"
              " code) and are computed again", file=sys.stderr)
    todo = [index for index in range(len(payloads)) if index not in finished]
    bar = progress_bar(total=len(payloads), initial=len(finished), unit="chunk", enabled=progress, desc=desc)
    interrupted = False
    try:
        if scheduler == "inline":
            for index in todo:
                result = task(shared, payloads[index])
                stopped = _was_interrupted(result)
                if not is_complete(result):  # stopped inside the chunk: nothing of it is kept
                    interrupted = True
                    break
                finished[index] = result
                store.save(index, result)
                bar.update(1)
                if stopped:  # the signal came as the chunk's last rollout ended: keep it, then stop
                    interrupted = True
                    break
        elif todo:
            _run_on_dask(task, shared, payloads, todo, scheduler, finished, store, bar, is_complete)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        bar.close()
    return finished, interrupted


def _was_interrupted(result) -> bool:
    return bool(result.pop("interrupted", False)) if isinstance(result, dict) else False


def _rollout_task(shared, payload):
    xml, name, t_final, seed, retire, nthread, engine, device, progress = shared
    return _run_chunk(xml, name, payload, t_final, seed, nthread, retire, engine, device, progress)


def run_study(robot: Robot, rollouts: RolloutSet, t_final: float, *, seed=0, scheduler="inline", store=None,
              chunk=CHUNK, retire=True, progress=False, desc="study", engine="mujoco", device=None) -> BatchResult:
    """All rollouts of a study, chunk by chunk, resuming from ``store`` (:func:`map_chunks`).

    Parameters
    ----------
    scheduler : "inline", "local" or a Dask scheduler address such as ``tcp://host:8786``
    store : ChunkStore, optional
        Where finished chunks are kept (and found again).
    engine, device : optional
        The engine of every chunk (:func:`~paa_mj.sim.batch.simulate_batch`): ``mujoco`` (default) or ``warp``, on
        the Warp ``device``; a study's key names a warp engine (:func:`engine_definition`), so that its chunks
        are never mixed with MuJoCo's.

    Returns
    -------
    BatchResult
        Rollouts of unfinished chunks are marked incomplete (``meta["completed"]``)
        and the result ``interrupted``.
    """
    n = len(rollouts)
    check_engine(engine, device)
    if engine == "warp":
        from ..sim.warp.device import load_warp

        load_warp()  # here, before any chunk: a missing install is one line, not one per chunk
    if not (isinstance(chunk, (int, np.integer)) and not isinstance(chunk, bool) and chunk >= 1):
        raise PaaError(f"--chunk must be a whole number >= 1, got {chunk!r}")
    check_memory(n * 8.0 * 40, "study results", "the grid or the number of trials")
    if scheduler in SCHEDULERS:  # here; a remote cluster's size is its own
        check_steps(n * t_final / float(robot.model.opt.timestep), f"{n} rollouts of {t_final:g} s",
                    "the grid, the number of trials or --t-final", links=robot.params.n_links, runs=n)
    starts = list(range(0, n, chunk))
    payloads = [rollouts.chunk(start, min(start + chunk, n)) for start in starts]
    if scheduler == "local" and len(payloads) == 1:  # one chunk: a cluster would only add its start-up
        scheduler = "inline"
    inline = scheduler == "inline"  # here, on all cores, the chunk's own progress shown; on Dask, one core each
    shared = (robot.xml, robot.name, t_final, seed, retire, None if inline else 1, engine, device,
              bool(progress and inline))
    finished, interrupted = map_chunks(_rollout_task, payloads, scheduler=scheduler, store=store, progress=progress,
                                       desc=f"{desc}, {n} rollouts", shared=shared, fits=_chunk_fits,
                                       is_complete=lambda result: bool(np.all(result["completed"])))
    return _merge(rollouts, starts, finished, chunk, n, interrupted, scheduler)


def _chunk_fits(payload, result) -> bool:
    """A kept chunk is this payload's: every outcome, one row per rollout, from the same initial states."""
    rows, width = np.shape(payload["x0"])
    widths = {"x0": width, "final_state": width, "max_abs_tau": width // 2 - 1}  # the others: one value per rollout
    shapes = {name: (rows, widths[name]) if name in widths else (rows,) for name in (*OUTCOMES, "completed")}
    return check_arrays(result, shapes) and np.array_equal(result["x0"], payload["x0"])


@contextlib.contextmanager
def _quiet_dask():
    """Dask's own logging says nothing while we run (its shutdown on Ctrl-C or lost workers is not news)."""
    names = ("distributed", "distributed.nanny", "distributed.scheduler", "distributed.worker", "distributed.core",
             "distributed.client", "distributed.comm", "tornado", "asyncio")
    levels = {name: logging.getLogger(name).level for name in names}
    for name in names:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", module="distributed")
            warnings.filterwarnings("ignore", message=".*already in use.*")
            yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """Worker processes started inside the block ignore Ctrl-C (they inherit the ignored signal).

    Ctrl-C in a terminal reaches the whole process group: the workers would each
    print a traceback, while this process is the one that stops them and keeps
    their finished chunks. Workers stopped that way leave semaphores that
    multiprocessing's resource tracker (started here, with these warning options)
    cleans up; its warning about them is not news either.
    """
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    quiet_tracker = "ignore:resource_tracker:UserWarning"
    sys.warnoptions.append(quiet_tracker)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        sys.warnoptions.remove(quiet_tracker)


def _run_on_dask(task, shared, payloads, todo, scheduler, finished, store, bar, is_complete):
    from distributed import Client, LocalCluster, as_completed

    total = len(finished) + len(todo)
    with _quiet_dask():
        cluster = None
        try:
            if scheduler == "local":
                try:
                    with _workers_ignore_ctrl_c():
                        cluster = LocalCluster(n_workers=None, threads_per_worker=1, processes=True,
                                               host="127.0.0.1", dashboard_address=None,
                                               silence_logs=logging.CRITICAL)
                except Exception as err:  # a worker that cannot start raises several types
                    raise PaaError(f"cannot start a local Dask cluster ({type(err).__name__}:"
                                   f" {' '.join(str(err).split())}); use --scheduler inline") from None
                client = Client(cluster)
            else:  # map_chunks has probed the address (check_scheduler)
                try:
                    client = Client(scheduler, timeout=5)
                except (OSError, TimeoutError, ValueError) as err:
                    raise PaaError(f"cannot reach the Dask scheduler {scheduler}: {' '.join(str(err).split())}") from None
            with client:
                remote = client.scatter(shared, broadcast=True)
                quiet_task = _StdoutToStderr(task)
                futures = {client.submit(quiet_task, remote, payloads[index], pure=False): index for index in todo}
                try:
                    for future in as_completed(futures):
                        try:
                            result = future.result()
                        except PaaError:
                            raise
                        except Exception as err:  # lost workers, a cancelled or killed task...
                            raise StudyIncomplete(
                                f"the Dask cluster stopped ({type(err).__name__}): {len(finished)} of {total}"
                                " chunks are done"
                                + (f" and kept in {store.path.parent.parent}; run the same command again to resume"
                                   if store.path is not None else "; give --out to keep finished chunks")) from None
                        _was_interrupted(result)  # workers ignore Ctrl-C: only a controller raises it there
                        if not is_complete(result):
                            raise StudyIncomplete(
                                f"a chunk came back unfinished from a Dask worker (a controller that raised"
                                f" KeyboardInterrupt?): {len(finished)} of {total} chunks are done")
                        finished[futures[future]] = result
                        store.save(futures[future], result)
                        bar.update(1)
                except BaseException:
                    client.cancel(list(futures))
                    raise
        finally:
            if cluster is not None:
                with contextlib.suppress(Exception):
                    cluster.close(timeout=10)


def _merge(rollouts, starts, finished, chunk, n, interrupted, scheduler) -> BatchResult:
    empty = {"switch_time": np.nan, "balanced": False, "final_state": np.nan, "E_minus_Er_final": np.nan,
             "V_final": np.nan, "max_abs_tau": np.nan, "diverged": False, "success": False, "t_end": np.nan,
             "status": -1, "t_region": np.nan, "t_balanced": np.nan, "int_tau2": np.nan, "work": np.nan,
             "smoothness": np.nan, "max_speed": np.nan}
    width = rollouts.x0.shape[1]
    widths = {"final_state": width, "max_abs_tau": width // 2 - 1}
    out = {"x0": rollouts.x0.copy()}
    for key, fill in empty.items():
        shape = (n, widths[key]) if key in widths else (n,)
        out[key] = np.full(shape, fill, dtype=type(fill) if isinstance(fill, bool) else None)
    out["status"] = out["status"].astype(np.int64)
    done = np.zeros(n, bool)
    for index, start in enumerate(starts):
        if index in finished:
            stop = min(start + chunk, n)
            for key in empty:
                out[key][start:stop] = finished[index][key]
            done[start:stop] = True
    t_end = out["t_end"][done]
    return BatchResult(**out, t_reached=float(np.max(t_end, initial=0.0)), task=rollouts.task,
                       interrupted=interrupted or not done.all(),
                       meta={"scheduler": scheduler, "completed": done})
