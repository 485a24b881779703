"""numba kernels of a fixed signature, compiled (or loaded from the cache) on first use instead of on import.

``njit(signature, cache=True)`` compiles, or loads from numba's cache, the moment its module is imported: a process
that imports the controller registry then loads the machine code of every controller and engine, used or not (about
2 CPU-s of the start-up of every command that imports the controllers, at 0.13.0). :func:`lazy_njit` gives the same
dispatcher, compiled for the same signature, cached in the same file under the same key, with compilation of other
signatures disabled as ``njit(signature)`` disables it; only the moment of the compilation moves: the first call
from Python, the first compilation of a kernel that calls it, or the first time it is passed as a first-class
function.
"""
from __future__ import annotations

from numba import njit
from numba.core import typeinfer
from numba.core.compiler_lock import global_compiler_lock
from numba.core.registry import CPUDispatcher


class LazyDispatcher(CPUDispatcher):
    """A CPU dispatcher compiled for its one signature (``_lazy_signature``) when first needed, then closed.

    Thread-safe: the engines call their kernels from several threads at once, and the first calls may race; the
    signature is compiled once, under numba's own compiler lock, and every caller then dispatches to it.
    """

    _lazy_signature = None

    def compile_lazily(self):
        """Compile (or load from the cache) the one signature, if not yet, and close compilation."""
        if self._lazy_signature is None or not self._can_compile:
            return
        with global_compiler_lock:  # re-entrant: a kernel that calls another compiles it inside this one
            if self._can_compile:
                with typeinfer.register_dispatcher(self):
                    self.compile(self._lazy_signature)
                self.disable_compile()

    def _compile_for_args(self, *args, **kws):  # a call from Python that matched no compiled signature
        if self._lazy_signature is None:
            return super()._compile_for_args(*args, **kws)
        self.compile_lazily()
        return self  # called again: the signature is compiled now, with numba's usual conversion or refusal

    def get_call_template(self, args, kws):  # typing a call from another kernel
        self.compile_lazily()
        return super().get_call_template(args, kws)

    def get_compile_result(self, sig):  # passed as a first-class function
        self.compile_lazily()
        return super().get_compile_result(sig)

    def _reduce_states(self):  # pickled (for a Dask worker): arrives compiled for its signature, as njit's would
        self.compile_lazily()
        return super()._reduce_states()


def lazy_njit(signature, **options):
    """``njit(signature, **options)`` compiled at first use (:class:`LazyDispatcher`); ``options`` as njit's."""

    def decorate(function):
        dispatcher = njit(**options)(function)  # no signature: nothing compiled yet
        dispatcher.__class__ = LazyDispatcher
        dispatcher._lazy_signature = signature
        return dispatcher

    return decorate
