"""Progress on stderr, whether or not stderr is a terminal.

On a terminal a bar redraws in place (tqdm). Redirected to a file or a pipe, the
same bar is written as whole lines, one every :data:`LOG_INTERVAL` seconds at
most and one at the end, each with the count, the rate and the time left, so a
log shows where a long command is and is never silent for long.
"""
from __future__ import annotations

import sys

from tqdm import tqdm

#: Seconds between two progress lines in a log.
LOG_INTERVAL = 10.0


class _Lines:
    """A stream for tqdm that turns its carriage-return redraws into lines."""

    def __init__(self, stream):
        self.stream = stream
        self.last = ""

    def write(self, text):
        for part in text.replace("\r", "\n").split("\n"):
            part = part.strip()
            if part and part != self.last:
                self.stream.write(part + "\n")
                self.last = part

    def flush(self):
        self.stream.flush()


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
        return tqdm(iterable, total=total, desc=desc, unit=unit, initial=initial, leave=leave, file=stream)
    return tqdm(iterable, total=total, desc=desc, unit=unit, initial=initial, leave=True, file=_Lines(stream),
                mininterval=LOG_INTERVAL, maxinterval=LOG_INTERVAL, ascii=True, ncols=100, dynamic_ncols=False)


def stage(message: str, enabled: bool = True):
    """One line on stderr naming what starts now (a step without a count of its own)."""
    if enabled:
        print(message, file=sys.stderr, flush=True)
