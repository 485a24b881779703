"""Output files are written whole or not at all: temporary file, then rename; sets of files all or none.

Also the lock that keeps two runs from writing into one output folder.
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import tempfile
import threading
from pathlib import Path

import numpy as np

from .errors import PaaError


def ensure_dir(path) -> Path:
    """Create an output folder, with a one-line error if that is impossible."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise PaaError(f"cannot create output folder {path}: {err.strerror or err}") from None
    if not os.access(path, os.W_OK):
        raise PaaError(f"output folder {path} is not writable")
    return path


@contextlib.contextmanager
def signals_held():
    """Ctrl-C and SIGTERM wait until the block ends, then act as usual.

    Around the writing of a set of files: a finished run interrupted while it is
    being saved is saved whole, then the interruption takes effect. Outside the main
    thread (where handlers cannot change) the block runs as is.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending = []
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(signum)
        if handler is None:  # set outside Python: cannot be restored, so left alone
            continue
        previous[signum] = signal.signal(signum, lambda number, frame: pending.append(number))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if pending:  # raised in this thread, so it acts before the block's caller goes on
            signal.raise_signal(pending[0])


def _check_target(final: Path):
    """An output path that exists must be a regular file: a device, a pipe or a link would be replaced."""
    if final.is_symlink():
        raise PaaError(f"{final} is a symbolic link: give the path of the file itself")
    if final.exists() and not final.is_file():
        raise PaaError(f"{final} exists and is not a regular file")


_UMASK = os.umask(0)
os.umask(_UMASK)


@contextlib.contextmanager
def atomic_path(final, suffix=None):
    """Yield a temporary path beside ``final``; rename it onto ``final`` only on success."""
    final = Path(final)
    _check_target(final)
    ensure_dir(final.parent if str(final.parent) else ".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=suffix or final.suffix, dir=final.parent)
    except OSError as err:
        raise PaaError(f"cannot write {final}: {err.strerror or err}") from None
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, final)
    except BaseException as err:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(err, OSError):
            raise PaaError(f"cannot write {final}: {err.strerror or err} (nothing was written)") from None
        raise


def write_text(path, text: str):
    with signals_held(), atomic_path(path) as tmp:
        tmp.write_text(text)


def write_json(path, obj):
    write_text(path, _json_file_text(obj))


def write_npz(path, **arrays):
    """An uncompressed .npz that ``np.load`` reads, byte-identical for identical arrays.

    ``np.savez`` stamps each member with the current time; a fixed stamp makes
    the same run give the same bytes.
    """
    with signals_held(), atomic_path(path, suffix=".npz") as tmp:
        _write_npz_file(tmp, arrays)


def _write_npz_file(path, arrays):
    import io as _io
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as zf:
        for name, value in arrays.items():
            buffer = _io.BytesIO()
            np.lib.format.write_array(buffer, np.asanyarray(value), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            zf.writestr(info, buffer.getvalue())


def _json_default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def strict_json(obj):
    """``obj`` with NumPy values as Python ones and NaN/inf as None, for strict JSON.

    JSON has no NaN or Infinity; Python would write them anyway and break every strict
    reader, so an undefined number (V without an energy law, say) is written as null.
    """
    if isinstance(obj, dict):
        return {key: strict_json(value) for key, value in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict_json(value) for value in obj]
    if isinstance(obj, np.ndarray):
        return strict_json(obj.tolist())
    if isinstance(obj, np.generic):
        return strict_json(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps(obj, **options) -> str:
    """Strict JSON text of ``obj`` (see :func:`strict_json`)."""
    return json.dumps(strict_json(obj), allow_nan=False, default=_json_default, **options)


def _json_file_text(obj) -> str:
    return dumps(obj, indent=2) + "\n"


def write_set(folder, writers: dict):
    """Write several files as a set, all or none: ``writers`` maps a file name to ``fn(path)``.

    Every file is first written to a temporary path beside its final name; only
    when all are written are they renamed into place. A failure (a full disk)
    leaves the folder as it was.
    """
    folder = ensure_dir(folder)
    for name in writers:
        _check_target(folder / name)
    with signals_held():
        return _write_set(folder, writers)


def _write_set(folder, writers):
    temporaries = []
    try:
        for name, writer in writers.items():
            final = folder / name
            fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=final.suffix, dir=folder)
            os.close(fd)
            temporaries.append((Path(tmp), final))
            writer(Path(tmp))
            os.chmod(tmp, 0o666 & ~_UMASK)
    except BaseException as err:
        for tmp, _ in temporaries:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if isinstance(err, OSError):
            raise PaaError(f"cannot write {', '.join(writers)} in {folder}: {err.strerror or err}"
                           " (nothing was written)") from None
        raise
    for tmp, final in temporaries:
        os.replace(tmp, final)
    return folder


def npz_writer(**arrays):
    """A writer for :func:`write_set` of a deterministic .npz (see :func:`write_npz`)."""
    return lambda path: _write_npz_file(path, arrays)


def json_writer(obj):
    return lambda path: path.write_text(_json_file_text(obj))


class OutputLock:
    """An exclusive lock on an output folder: a second run writing there refuses with one line.

    The lock is an ``flock`` on ``FOLDER/.paa-mj.lock``, released when the
    process ends, however it ends; a run that ends normally also removes the
    file, so the folder holds only what the run wrote.
    """

    def __init__(self, folder):
        self.folder = ensure_dir(folder)
        self.path = self.folder / ".paa-mj.lock"
        self.handle = None

    def __enter__(self):
        import fcntl

        while True:
            try:
                handle = open(self.path, "a+")
            except OSError as err:  # a full disk (no inode left), a read-only file system...
                raise PaaError(f"cannot lock output folder {self.folder}: {err.strerror or err}") from None
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                handle.seek(0)
                holder = handle.read().strip() or "another process"
                handle.close()
                raise PaaError(f"another paa-mj run ({holder}) is writing to {self.folder}: wait for it, or"
                               " choose another --out") from None
            # The holder before us may have removed the file between our open and our lock: then the lock we
            # hold is on a file nobody else will find, and we take the one at the path instead.
            try:
                same = os.stat(self.path).st_ino == os.fstat(handle.fileno()).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            handle.close()
        self.handle = handle
        try:
            self.handle.seek(0)
            self.handle.truncate()
            self.handle.write(f"pid {os.getpid()}")
            self.handle.flush()
        except OSError as err:
            # a full disk takes the file but not its text: the lock is let go, and its file removed
            self.__exit__(None, None, None)
            raise PaaError(f"cannot lock output folder {self.folder}: {err.strerror or err}") from None
        return self

    def __exit__(self, *exc):
        if self.handle is not None:
            try:
                os.unlink(self.path)
            except OSError:
                pass
            with contextlib.suppress(OSError):  # a close that flushes onto a full disk: the file is gone already
                self.handle.close()
            self.handle = None
