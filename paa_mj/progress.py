"""Progress on stderr, whether or not stderr is a terminal.

On a terminal a bar redraws in place (tqdm). Redirected to a file or a pipe, the
same bar is written as whole lines, the first after :data:`LOG_DELAY` seconds
(work that is done by then, or fails, adds none), then one every
:data:`LOG_INTERVAL` seconds at most and one at the end, each with the count,
the rate and the time left, so a log shows where a long command is. A command's :func:`watchdog` adds a
line whenever nothing has been said for :data:`SILENCE` seconds (a step with no
count of its own: compiling the kernels, a solve), so a log is never silent for
long. ``PAA_MJ_PROGRESS=off`` in the environment leaves both out of a log (a
terminal's bars stay): what a log says is then the same on a fast machine and on
a loaded one.
"""
from __future__ import annotations

import contextlib
import math
import os
import sys
import threading
import time

from tqdm import tqdm

#: Seconds between two progress lines in a log.
LOG_INTERVAL = 10.0
#: A log's first progress line comes after this many seconds (work that ends sooner, or fails at once, adds none).
LOG_DELAY = 2.0
#: Seconds without a line after which a command's :func:`watchdog` writes one.
SILENCE = 20.0

#: When a progress line was last written, and what it said (read by :func:`watchdog`).
_last = {"time": time.monotonic(), "what": ""}


def lines_in_logs() -> bool:
    """False where ``PAA_MJ_PROGRESS`` is ``off`` (or ``0``, ``no``): no progress lines in a log."""
    return os.environ.get("PAA_MJ_PROGRESS", "").strip().lower() not in ("off", "0", "no")


def _said(what: str):
    _last["time"], _last["what"] = time.monotonic(), what


class _LogBar:
    """A progress counter for a log: whole lines (count, rate, time left), never a redraw."""

    def __init__(self, iterable, total, desc, unit, initial, stream):
        self.iterable, self.total, self.desc, self.unit = iterable, total, desc, unit
        self.n, self.stream = initial, stream
        if total is None and iterable is not None and hasattr(iterable, "__len__"):
            self.total = len(iterable)
        self.start = self.last = time.monotonic()
        self.initial, self.shown, self.shown_n, self.shown_total = initial, False, None, total

    def __iter__(self):
        for item in self.iterable:
            yield item
            self.update(1)

    def update(self, n=1):
        self.n += n
        now = time.monotonic()
        due = LOG_INTERVAL if self.shown else LOG_DELAY
        unfinished = self.total is None or self.n < self.total
        if now - self.last >= due and unfinished:  # work that ends before its first line is due says nothing
            self._line(now)

    def set_description_str(self, desc=None, refresh=True):
        """What the next lines say before the count (tqdm's method; ``refresh`` is tqdm's, unused here)."""
        self.desc = desc

    def _line(self, now):
        n, total = _shown(self.n), _shown(self.total)  # 11.8/30.0 s simulated, not 11.778875/30.0
        text = tqdm.format_meter(n, total, now - self.start, ncols=0, prefix=self.desc or "",
                                 unit=self.unit, initial=self.initial, ascii=True)
        self.stream.write(text.strip() + "\n")
        self.stream.flush()
        _said(text.strip())
        self.last, self.shown, self.shown_n, self.shown_total = now, True, self.n, self.total

    def close(self):
        now = time.monotonic()
        if self.shown and (self.shown_n != self.n or self.shown_total != self.total):
            self._line(now)
        self.shown = False
        self.start = self.last = math.inf  # closed: no more lines

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


#: Decimals of a count that is not whole (simulated seconds): enough to see it move, none of the float's noise.
DECIMALS = 1
#: tqdm's bar with such a count shown at :data:`DECIMALS` (its own would show 11.778875/30.0).
FLOAT_BAR = ("{l_bar}{bar}| {n:.%df}/{total:.%df} [{elapsed}<{remaining}, {rate_fmt}{postfix}]"
             % (DECIMALS, DECIMALS))


def _shown(count):
    """A count as a bar shows it: a whole number as it is, another rounded to :data:`DECIMALS`."""
    return round(count, DECIMALS) if isinstance(count, float) else count


def finish(bar):
    """Close ``bar`` at 100 %: its total becomes the count reached (work whose total was only a bound, such as a
    solver's iteration limit, ends where it ends)."""
    bar.total = bar.n
    if hasattr(bar, "refresh") and not getattr(bar, "disable", False):
        bar.refresh()
    bar.close()


def progress(iterable=None, *, total=None, desc=None, unit="it", enabled=True, initial=0, leave=False):
    """A progress bar on stderr (a tqdm object; ``enabled=False`` gives a silent one).

    Parameters
    ----------
    iterable : iterable, optional
    total : int or float, optional
    desc, unit : str
        What is counted, as tqdm shows it.
    enabled : bool
        False: nothing is shown (the object still counts).
    initial : int
        Already done (a resumed study).
    leave : bool
        Keep the finished bar on a terminal (a log always keeps its last line).
    """
    if not enabled:
        return tqdm(iterable, total=total, initial=initial, disable=True)
    stream = sys.stderr
    if stream is not None and hasattr(stream, "isatty") and stream.isatty():
        whole = not isinstance(total, float) and not isinstance(initial, float)
        return tqdm(iterable, total=total, desc=desc, unit=unit, initial=initial, leave=leave, file=stream,
                    **({} if whole or total is None else {"bar_format": FLOAT_BAR}))
    if not lines_in_logs():
        return tqdm(iterable, total=total, initial=initial, disable=True)
    return _LogBar(iterable, total, desc, unit, initial, stream)


def stage(message: str, enabled: bool = True):
    """One line on stderr naming what starts now (a step without a count of its own)."""
    if enabled:
        print(message, file=sys.stderr, flush=True)
        _said(message)


@contextlib.contextmanager
def watchdog(command: str, enabled: bool = True, silence: float = SILENCE, stream=None):
    """While the block runs, a line on ``stream`` (stderr) whenever no progress line has been written for
    ``silence`` seconds: how long the command has run and the last thing said, so that a log is never silent for
    long, whatever the step (compiling the kernels, a solve, a wait on workers).

    Nothing on a terminal, where tqdm's bars redraw in place, when ``enabled`` is False, or where
    ``PAA_MJ_PROGRESS=off`` (:func:`lines_in_logs`).
    """
    stream = sys.stderr if stream is None else stream
    if not enabled or not lines_in_logs() or stream is None or (hasattr(stream, "isatty") and stream.isatty()):
        yield
        return
    start = time.monotonic()
    _said("")
    stop = threading.Event()

    def watch():
        while not stop.wait(min(1.0, silence / 4)):
            now = time.monotonic()
            if now - _last["time"] >= silence:
                what = _last["what"] if len(_last["what"]) <= 100 else _last["what"][:97] + "..."
                with contextlib.suppress(OSError, ValueError):  # a closed stderr: nothing to tell
                    stream.write(f"{command}: still working, {now - start:.0f} s in"
                                 + (f" (last: {what})" if what else "") + "\n")
                    stream.flush()
                _last["time"] = now

    thread = threading.Thread(target=watch, name="paa-mj watchdog", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(timeout=5.0)
