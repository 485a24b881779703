"""What identifies a result's making: the package's code, a robot's model text.

Cached and kept results (trajectory plans, study chunks) are keyed by these
digests, so that a result made by other code or for another robot is never
served in place of the one asked for.
"""
from __future__ import annotations

import functools
import hashlib
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


def text_sha256(text: str) -> str:
    """The sha256 of a text (a robot's MJCF) in UTF-8, hexadecimal."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def key_numba_cache_by_code():
    """Keep numba's compiled kernels in a folder of :func:`cache_root` named by :func:`package_digest`.

    numba's own cache (``cache=True``) checks only the source file of each compiled function, not those of the
    functions it calls from other modules: after a change to a callee alone (a ``git pull``), the caller's
    cached machine code would still run the old callee. Keyed by the digest of all the package's code, a
    changed package compiles afresh. Left alone where the user set ``NUMBA_CACHE_DIR`` or the folder cannot
    be written (numba then caches beside the sources, as it does by default).
    """
    import sys

    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    path = cache_root() / "numba" / package_digest()[:16]
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return
    if not os.access(path, os.W_OK):
        return
    os.environ["NUMBA_CACHE_DIR"] = str(path)
    numba = sys.modules.get("numba")
    if numba is not None:  # imported before the package: its configuration is read already
        numba.config.CACHE_DIR = str(path)
