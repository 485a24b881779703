"""Finished chunks of a study kept on disk, so that a study stopped for any reason resumes where it stopped.

A study is cut into chunks, always the same way. With an output folder, each
chunk is written as it finishes (atomically) to ``OUT/.chunks/KEY/chunk-NNNNN.npz``,
where KEY is a digest of everything that defines the study (robot, controllers,
grid, levels, times, seeds). Running the same command again loads the chunks
already there and computes only the others, so an interrupted study ends
byte-identical to an uninterrupted one; a different study in the same folder
gets another KEY and is refused unless ``--fresh``, which deletes the chunks first.
"""
from __future__ import annotations

import re
import shutil
import sys
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..io import ensure_dir, write_npz
from ..provenance import definition_digest, package_digest


def study_key(definition: dict) -> str:
    """A digest of a study's definition (any JSON-able dict with arrays: the robot's MJCF text, every
    controller's recipe and source, every option that changes a result) and of the package (version and code)."""
    from .. import __version__

    return definition_digest({"version": __version__, "package": package_digest(), **definition})[:20]


_LEGACY_KEY = re.compile(r"[0-9a-f]{20}")


class ChunkStore:
    """The chunks of one study under ``folder/.chunks/STUDY-KEY``; ``folder=None`` keeps nothing.

    A folder keeps the chunks of one study of each kind (``STUDY``): chunks of another study of that kind (another
    KEY: other options, controller or code) are refused in one line, never removed unless ``fresh`` (``--fresh``,
    which also forgets this study's own).
    """

    def __init__(self, folder, key: str, fresh: bool = False, study: str = "study"):
        self.path = None if folder is None else Path(folder) / ".chunks" / f"{study}-{key}"
        if self.path is not None:
            if fresh and self.path.exists():
                shutil.rmtree(self.path)
            siblings = [p for p in self.path.parent.iterdir() if p.is_dir()] if self.path.parent.is_dir() else []
            # the same kind of study with another key, or a folder of version 0.2 (its key alone, no kind)
            stale = [p for p in siblings if p != self.path and (p.name.startswith(f"{study}-")
                                                                or _LEGACY_KEY.fullmatch(p.name))]
            if stale and not fresh:
                raise PaaError(f"{folder} keeps the finished chunks of another {study} study (other options, controller"
                               " or version of paa_mj): give --fresh to replace them, or choose another --out")
            for old in stale:
                shutil.rmtree(old, ignore_errors=True)
            if stale:
                print(f"note: --fresh: removed the kept chunks of an earlier, different {study} study in {folder}",
                      file=sys.stderr)
            ensure_dir(self.path)

    def _file(self, index):
        return self.path / f"chunk-{index:05d}.npz"

    def load(self, index: int):
        """The arrays of a finished chunk, or None."""
        if self.path is None or not self._file(index).is_file():
            return None
        try:
            with np.load(self._file(index), allow_pickle=False) as z:
                return {k: np.array(z[k]) for k in z.files}
        except Exception:  # a damaged chunk is computed again
            return None

    def save(self, index: int, arrays: dict):
        if self.path is not None:
            try:
                write_npz(self._file(index), **arrays)
            except PaaError as err:
                raise PaaError(f"cannot keep a finished chunk: {err}") from None

    def count(self) -> int:
        return 0 if self.path is None else len(list(self.path.glob("chunk-*.npz")))


def check_arrays(arrays, shapes: dict) -> bool:
    """True when ``arrays`` holds exactly the names of ``shapes``, each of that shape (None: any length there)."""
    if not isinstance(arrays, dict) or set(arrays) != set(shapes):
        return False
    for name, shape in shapes.items():
        actual = np.shape(arrays[name])
        if len(actual) != len(shape) or any(want is not None and got != want for got, want in zip(actual, shape)):
            return False
    return True


#: How every study's outputs mark a run it never did (an interrupted study): ``null`` in its JSON (never ``false``,
#: which is a failure), False in the ``completed`` mask of its arrays, and the count in its summary.
NOT_RUN = None


def runs_done(completed) -> dict:
    """What every study's summary says of its runs: how many there are, how many were not run (an interrupted
    study's, whose entries are :data:`NOT_RUN`) and the fraction completed."""
    done = np.asarray(completed, bool).ravel()
    return {"runs": int(done.size), "not_run": int(done.size - np.count_nonzero(done)),
            "completed_fraction": float(np.mean(done)) if done.size else 1.0}


def per_run(values, completed) -> list:
    """Each run's value for a JSON list, :data:`NOT_RUN` (null) for a run not run."""
    return [NOT_RUN if not done else value for value, done in zip(values, completed)]


def not_run_words(summary, unit="runs") -> str:
    """"k of N runs not run" for an incomplete study's summary, else ""."""
    return f"{summary['not_run']} of {summary['runs']} {unit} not run" if summary.get("not_run") else ""
