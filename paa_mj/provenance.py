"""What identifies a result's making: the package's code, a robot's model text.

Cached and kept results (trajectory plans, study chunks) are keyed by these
digests, so that a result made by other code or for another robot is never
served in place of the one asked for.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
from pathlib import Path


def cache_root() -> Path:
    """Where the package keeps what it can compute again: ``$PAA_MJ_CACHE``, else ``$XDG_CACHE_HOME/paa_mj`` or
    ``~/.cache/paa_mj``."""
    return Path(os.environ.get("PAA_MJ_CACHE") or os.path.join(os.environ.get("XDG_CACHE_HOME") or
                                                                os.path.expanduser("~/.cache"), "paa_mj"))


@functools.lru_cache(maxsize=1)
def package_digest() -> str:
    """The sha256 of the package's own code and model files (hexadecimal)."""
    root = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        if path.suffix in (".py", ".xml") and "__pycache__" not in path.parts:
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def definition_digest(definition: dict) -> str:
    """The sha256 (hexadecimal) of a result's ``definition``: JSON with sorted keys, where an array stands for the
    digest of its bytes, shape and type (a million starts hash in milliseconds, not as a million lists)."""
    import numpy as np

    from .io import _json_default

    def default(obj):
        if isinstance(obj, np.ndarray) and obj.dtype != object:
            data = np.ascontiguousarray(obj)
            return {"array_sha256": hashlib.sha256(data.tobytes()).hexdigest(), "shape": list(data.shape),
                    "dtype": data.dtype.str}
        return _json_default(obj)

    return hashlib.sha256(json.dumps(definition, sort_keys=True, default=default).encode()).hexdigest()


def cache_key(**definition) -> str:
    """The name of a cached result: 24 hexadecimal digits of the digest (:func:`definition_digest`) of its
    ``definition`` (JSON-able, arrays included) and of the package's code."""
    return definition_digest({"package": package_digest(), **definition})[:24]


def kept(kind: str, compute, *, encode=None, decode=None, **definition):
    """A result that costs more than a second to compute, computed once per content and kept on disk.

    Kept in ``cache_root()/kind`` under :func:`cache_key` of ``definition`` (every input of the result: the robot's
    parameters, the task, weights, limits, step, method, samples...) and of the package's code, so that a result
    of other inputs or other code is never served. ``compute()`` makes it; ``encode`` turns it into JSON data
    (floats written exactly, infinities and NaN included) and ``decode`` back. A kept file that cannot be read is
    computed again; one that cannot be written costs a computation next time, nothing else. (kD_min (41) keeps
    its searches the same way, with the budget they had: :func:`paa_mj.theory.kd_search.kept_search`.)
    """
    encode = encode or (lambda result: result)
    decode = decode or (lambda data: data)
    path = cache_root() / kind / f"{cache_key(kind=kind, **definition)}.json"
    try:
        return decode(json.loads(path.read_text()))
    except (OSError, ValueError, TypeError, KeyError):
        pass
    result = compute()
    from .errors import PaaError
    from .io import _json_default, write_text

    try:
        write_text(path, json.dumps(encode(result), default=_json_default))
    except (PaaError, OSError, TypeError, ValueError):
        pass
    return result


def text_sha256(text: str) -> str:
    """The sha256 of a text (a robot's MJCF) in UTF-8, hexadecimal."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def numba_jit_disabled() -> bool:
    """True where ``NUMBA_DISABLE_JIT`` asks numba to run its functions uncompiled (as numba reads it)."""
    value = os.environ.get("NUMBA_DISABLE_JIT", "0").strip()
    try:
        return int(value or "0") != 0
    except ValueError:
        return True


def require_compiled_kernels():
    """Refuse, in one line, ``NUMBA_DISABLE_JIT``: the physics calls MuJoCo from compiled code, through addresses
    that uncompiled Python cannot follow, so uncompiled the robots would not move (every run its start)."""
    from .errors import PaaError

    if numba_jit_disabled():
        raise PaaError(f"NUMBA_DISABLE_JIT={os.environ.get('NUMBA_DISABLE_JIT')!r} is set: paa_mj's physics runs"
                       " as compiled code only (uncompiled, MuJoCo would not be stepped); unset it")


def _writable_folder(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(path, os.W_OK | os.X_OK)


def numba_cache_folder() -> Path:
    """Where the package's compiled kernels are kept: a folder named by :func:`package_digest`, inside
    ``$NUMBA_CACHE_DIR`` where the user set it, else inside :func:`cache_root`, else (neither writable) inside
    the temporary folder."""
    import tempfile

    name = package_digest()[:16]
    user = os.environ.get("PAA_MJ_NUMBA_CACHE_BASE") or os.environ.get("NUMBA_CACHE_DIR")
    bases = [Path(user)] if user else [cache_root() / "numba"]
    bases.append(Path(tempfile.gettempdir()) / f"paa_mj-numba-{os.getuid() if hasattr(os, 'getuid') else 0}")
    for base in bases:
        if _writable_folder(base / name):
            return base / name
    from .errors import PaaError

    raise PaaError(f"no writable folder for the compiled kernels ({', '.join(str(b) for b in bases)}): set"
                   " PAA_MJ_CACHE to a writable folder")


def key_numba_cache_by_code():
    """Keep numba's compiled kernels in :func:`numba_cache_folder`, and drop unreadable entries.

    numba's own cache (``cache=True``) checks only the source file of each compiled function, not those of the
    functions it calls from other modules: after a change to a callee alone (a ``git pull``), the caller's
    cached machine code would still run the old callee. Keyed by the digest of all the package's code, a
    changed package compiles afresh, wherever the cache is (a ``NUMBA_CACHE_DIR`` of the user's gets a
    subfolder per digest). A cache file that cannot be read (truncated, zero-filled) is removed and its
    kernel compiled again (:func:`_drop_unreadable_cache_entries`).
    """
    import sys

    try:
        path = numba_cache_folder()
    except Exception:  # noqa: BLE001 - reported by the CLI (check_numba_cache); importing must not fail
        return
    if "PAA_MJ_NUMBA_CACHE_BASE" not in os.environ:  # the user's base, kept for processes started from this one
        os.environ["PAA_MJ_NUMBA_CACHE_BASE"] = str(path.parent)
    os.environ["NUMBA_CACHE_DIR"] = str(path)
    numba = sys.modules.get("numba")
    if numba is not None:  # imported before the package: its configuration is read already
        numba.config.CACHE_DIR = str(path)
    _when_imported("numba.core.caching", _drop_unreadable_cache_entries)


class _AfterImport:
    """A finder that runs ``then(module)`` once ``name`` has been imported (numba is not imported for this alone:
    ``paa-mj --help`` answers before it loads)."""

    def __init__(self, name, then):
        self.name, self.then = name, then

    def find_spec(self, fullname, path=None, target=None):
        if fullname != self.name:
            return None
        import importlib.util
        import sys

        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None:
            return spec
        exec_module = spec.loader.exec_module

        def run_then(module):
            exec_module(module)
            self.then(module)

        spec.loader.exec_module = run_then
        return spec


def _when_imported(name, then):
    import sys

    if name in sys.modules:
        then(sys.modules[name])
    elif not any(isinstance(f, _AfterImport) and f.name == name for f in sys.meta_path):
        sys.meta_path.insert(0, _AfterImport(name, then))


def _drop_unreadable_cache_entries(caching):
    """numba's cache files, when they cannot be unpickled, removed and treated as absent (compiled again)
    instead of failing every command with an ``UnpicklingError``."""
    cache_file = caching.IndexDataCacheFile
    if getattr(cache_file, "_paa_mj_guarded", False):
        return
    load_index, load_data = cache_file._load_index, cache_file._load_data

    def _load_index(self):
        try:
            return load_index(self)
        except OSError:
            raise
        except Exception:  # noqa: BLE001 - an unreadable index is as good as none
            _remove(self._index_path)
            return {}

    def _load_data(self, name):
        try:
            return load_data(self, name)
        except OSError:
            raise
        except Exception as err:  # noqa: BLE001 - load() treats an OSError as a missing entry
            _remove(self._data_path(name))
            raise OSError(f"unreadable cache entry {name}") from err

    cache_file._load_index, cache_file._load_data = _load_index, _load_data
    cache_file._paa_mj_guarded = True


def _remove(path):
    try:
        os.unlink(path)
    except OSError:
        pass
