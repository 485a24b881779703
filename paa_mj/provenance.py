"""What identifies a result's making: the package's code, a robot's model text.

Cached and kept results (trajectory plans, study chunks) are keyed by these
digests, so that a result made by other code or for another robot is never
served in place of the one asked for.
"""
from __future__ import annotations

import functools
import hashlib
from pathlib import Path


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
