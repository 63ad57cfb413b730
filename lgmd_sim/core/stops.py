"""Signals that stop a run, and where Python would lose them.

A SIGTERM or Ctrl-C becomes an exception in the main thread; raised inside a C callback (a
GL driver's, numba's compiler), a ``__del__`` or a weakref callback, Python prints it and
goes on, and inside a ctypes call's argument conversion it comes back as a
ctypes.ArgumentError naming it. `catch_swallowed_stops` (a process-wide hook) and
`reraise_stop_from_ctypes` (at such a call) make the signal come again, so that the
process stops as it was told; `held_stops` defers the handlers over a span that must not
be cut (starting a worker process). A handler calls `stop_raised` as it raises: what the
cleanups the stop cut short raise later (a half-freed object's ``__del__``) is then kept
quiet, so that a stopped command says one line.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import Any

__all__ = ["STOPPING", "catch_swallowed_stops", "held_stops", "reraise_stop_from_ctypes",
           "stop_raised", "stopping"]

#: The signals that stop a run.
STOPPING = {signal.SIGINT, signal.SIGTERM}
#: Set once a stop's exception has been raised in this process (`stop_raised`).
_RAISED = threading.Event()


def stop_raised() -> None:
    """Note that a stop is being raised in this process (its signal handler calls this)."""
    _RAISED.set()


def stopping() -> bool:
    """Whether a stop has been raised in this process (`stop_raised`)."""
    return _RAISED.is_set()


def catch_swallowed_stops(stops: Mapping[type[BaseException], int]) -> Callable[[Any], None]:
    """Make sure a signal that stops this process does: `stops` are the exceptions its
    handlers raise, each with its signal. Raised where Python cannot pass it on (a C
    callback, as numba's compiler makes, a ``__del__``, a weakref callback), one would be
    printed and swallowed, and the process go on, as would a ctypes.ArgumentError naming
    one there (`reraise_stop_from_ctypes`): instead the signal comes again a moment later,
    quietly. Once a stop has been raised (`stop_raised`), anything else raised there is
    dropped: it comes from a cleanup the stop cut short (a library's half-closed object
    whose ``__del__`` then fails), in a process that is ending. Installs a
    `sys.unraisablehook`; returns the one it replaces."""
    previous = sys.unraisablehook
    _RAISED.clear()

    def hook(unraisable: Any) -> None:
        signum = _stop_of(unraisable.exc_type, unraisable.exc_value, stops)
        if signum is None:
            if not _RAISED.is_set():
                previous(unraisable)
            return
        again = threading.Timer(0.01, os.kill, (os.getpid(), signum))
        again.daemon = True
        again.start()

    hook.stops = dict(stops)  # type: ignore[attr-defined]  # for reraise_stop_from_ctypes
    sys.unraisablehook = hook
    return previous


def reraise_stop_from_ctypes(exc: BaseException) -> None:
    """A stop that came while ctypes converted a C call's arguments (a GL driver's) comes
    back as a ctypes.ArgumentError naming it ("argument 3: KeyboardInterrupt: "): send its
    signal again, so that the handler stops the program as it would have (it raises during
    the wait). The stops are those `catch_swallowed_stops` installed, and Ctrl-C's
    KeyboardInterrupt always; anything else returns."""
    stops = {KeyboardInterrupt: signal.SIGINT, **getattr(sys.unraisablehook, "stops", {})}
    signum = _stop_of(type(exc), exc, stops) if isinstance(exc, ctypes.ArgumentError) else None
    if signum is not None:
        os.kill(os.getpid(), signum)
        time.sleep(1.0)


def _stop_of(kind: type[BaseException], exc: BaseException | None,
             stops: Mapping[type[BaseException], int]) -> int | None:
    """The signal of the stop that `exc` (of class `kind`) is, or that it names as a
    ctypes.ArgumentError (ctypes gives the class's name: "argument 3: Terminated: "), among
    `stops`; None for anything else."""
    named = (str(exc).partition(": ")[2].partition(":")[0]
             if issubclass(kind, ctypes.ArgumentError) else None)
    for stop, signum in stops.items():
        if issubclass(kind, stop) or stop.__name__ == named:
            return signum
    return None


@contextmanager
def held_stops() -> Iterator[None]:
    """Hold the stopping signals' handlers until the block ends, then run them. Blocking
    the signals in this thread is not enough: another thread of the process (OpenBLAS's,
    pyarrow's) takes a signal sent to the process, and Python then runs its handler here
    all the same."""
    if threading.current_thread() is not threading.main_thread():
        yield  # handlers can be set from the main thread only; signals are run there
        return
    caught: list[int] = []
    held = {s: signal.signal(s, lambda signum, frame: caught.append(signum))
            for s in STOPPING}
    try:
        yield
    finally:
        for s, handler in held.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for s in caught:
            os.kill(os.getpid(), s)  # now, to the handlers of the run
