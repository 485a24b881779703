"""Package namespaces whose names are imported on first use (PEP 562).

Importing one light module of the package (the command line's help, a table of
names) then loads no more than it needs: not MuJoCo, numba or SciPy.
"""
from __future__ import annotations

import importlib


def lazy_exports(package: str, exports: dict, namespace: dict):
    """``(__getattr__, __dir__)`` for ``package``, importing ``exports[name]`` (a relative module) on first use."""

    def __getattr__(name):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(exports[name], package), name)
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
