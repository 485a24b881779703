"""Running a study's rollouts in fixed chunks: in this process, or on Dask (local or any cluster).

A study is cut into chunks of ``CHUNK`` rollouts, always the same way, and each
chunk gets its own seed ``[seed, chunk index]``; a chunk is one call of
:func:`paa_mj.batch.simulate_batch`. So the results are identical whichever way
the chunks run: inline, on a local Dask cluster (the default when Dask is
installed), or on any cluster given by its scheduler address. Workers rebuild
the robot from its MJCF text, so a remote cluster needs no files of ours.
Ctrl-C stops cleanly and keeps the chunks already finished.
"""
from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from .batch import BatchResult, simulate_batch
from .errors import PaaError
from .model import Robot, robot_from_xml

CHUNK = 128
#: Arguments of simulate_batch that may hold one entry per rollout, and the number of dimensions
#: they have when they do (a lower one means one value shared by every rollout).
PER_ROLLOUT_NDIM = {"x0": 2, "gains": 2, "noise_std": 2, "torque_limit": 1, "delay_steps": 1,
                    "plant_params": None, "controller_params": None}  # None: a list, one entry per rollout


def dask_available() -> bool:
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def _split(kwargs, n, chunk):
    for index, start in enumerate(range(0, n, chunk)):
        part = dict(kwargs)
        for key, ndim in PER_ROLLOUT_NDIM.items():
            value = kwargs.get(key)
            if value is None:
                continue
            if ndim is None or np.ndim(value) == ndim:
                part[key] = value[start:start + chunk]
        part["seed"] = [kwargs.get("seed", 0), index]
        yield index, part


def _run_chunk(xml, name, kwargs, nthread):
    robot = robot_from_xml(xml, name=name)
    result = simulate_batch(robot, nthread=nthread, **kwargs)
    return {key: getattr(result, key) for key in _FIELDS} | {"t_reached": result.t_reached,
                                                           "interrupted": result.interrupted}


_FIELDS = ("x0", "switch_time", "balanced", "final_state", "E_minus_Er_final", "V_final", "max_abs_tau", "diverged",
           "held")


def run_rollouts(robot: Robot, x0, scheduler=None, chunk=CHUNK, progress=False, **kwargs) -> BatchResult:
    """All rollouts of a study, chunk by chunk.

    Parameters
    ----------
    scheduler : None, "inline", "local" or an address such as ``tcp://host:8786``
        None: a local Dask cluster when Dask is installed, else inline.
    kwargs
        Passed to :func:`simulate_batch`; per-rollout entries are split with ``x0``.
    """
    if robot.xml is None:
        raise PaaError("the robot must come from MJCF text (load_robot or robot_from_xml) to be sent to workers")
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    n = len(x0)
    chunks = list(_split({"x0": x0, **kwargs}, n, chunk))
    if scheduler is None:
        scheduler = "local" if dask_available() else "inline"
    finished, interrupted = {}, False
    bar = tqdm(total=len(chunks), unit="chunk", disable=None if progress else True, desc=f"{n} rollouts")
    try:
        if scheduler == "inline":
            for index, part in chunks:
                finished[index] = _run_chunk(robot.xml, robot.name, part, nthread=None)
                bar.update(1)
                if finished[index]["interrupted"]:  # Ctrl-C inside the chunk: keep it, stop here
                    interrupted = True
                    break
        else:
            _run_on_dask(robot, chunks, scheduler, finished, bar)
    except KeyboardInterrupt:
        interrupted = True
    bar.close()
    return _merge(chunks, finished, n, chunk, interrupted, scheduler)


def _run_on_dask(robot, chunks, scheduler, finished, bar):
    if not dask_available():
        raise PaaError("Dask is not installed: pip install 'paa_mj[dask]' (or use --scheduler inline)")
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    try:
        if scheduler == "local":
            cluster = LocalCluster(n_workers=None, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout=5)
            except (OSError, TimeoutError, ValueError) as err:
                raise PaaError(f"cannot reach the Dask scheduler {scheduler}: {' '.join(str(err).split())}") from None
        with client:
            xml = client.scatter(robot.xml, broadcast=True)
            futures = {client.submit(_run_chunk, xml, robot.name, part, 1, pure=False): index for index, part in chunks}
            try:
                for future in as_completed(futures):
                    finished[futures[future]] = future.result()
                    bar.update(1)
            except KeyboardInterrupt:
                client.cancel(list(futures))
                raise
    finally:
        if cluster is not None:
            cluster.close()


def _merge(chunks, finished, n, chunk, interrupted, scheduler):
    out = {"x0": np.full((n, 6), np.nan), "switch_time": np.full(n, np.nan), "balanced": np.zeros(n, bool),
           "final_state": np.full((n, 6), np.nan), "E_minus_Er_final": np.full(n, np.nan), "V_final": np.full(n, np.nan),
           "max_abs_tau": np.full((n, 2), np.nan), "diverged": np.zeros(n, bool), "held": np.zeros(n, bool)}
    done = np.zeros(n, bool)
    t_reached = []
    for index, part in chunks:
        start = index * chunk
        stop = start + len(part["x0"])
        if index in finished and not finished[index]["interrupted"]:
            for key in _FIELDS:
                out[key][start:stop] = finished[index][key]
            done[start:stop] = True
            t_reached.append(finished[index]["t_reached"])
        else:
            out["x0"][start:stop] = part["x0"]
    result = BatchResult(**out, t_reached=min(t_reached) if t_reached else 0.0,
                         interrupted=interrupted or not done.all(), meta={"scheduler": scheduler})
    result.meta["completed"] = done
    return result
