"""Finished chunks of a study kept on disk, so that a study stopped for any reason resumes where it stopped.

A study is cut into chunks, always the same way. With an output folder, each
chunk is written as it finishes (atomically) to ``OUT/.chunks/KEY/chunk-NNNNN.npz``,
where KEY is a digest of everything that defines the study (robot, controllers,
grid, levels, times, seeds). Running the same command again loads the chunks
already there and computes only the others, so an interrupted study ends
byte-identical to an uninterrupted one; a different study in the same folder
gets another KEY. ``--fresh`` deletes the study's chunks first.
"""
from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..io import _json_default, ensure_dir, write_npz


def study_key(definition: dict) -> str:
    """A digest of a study's definition (any JSON-able dict with arrays) and of the package's version."""
    from .. import __version__

    text = json.dumps({"version": __version__, **definition}, sort_keys=True, default=_json_default)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


class ChunkStore:
    """The chunks of one study under ``folder/.chunks/key``; ``folder=None`` keeps nothing."""

    def __init__(self, folder, key: str, fresh: bool = False):
        self.path = None if folder is None else Path(folder) / ".chunks" / key
        if self.path is not None:
            if fresh and self.path.exists():
                shutil.rmtree(self.path)
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
