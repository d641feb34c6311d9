"""Ctrl-C and SIGTERM: a command that is interrupted stops at once, cleans up and says so in one
line (exit status 130), whatever code was running when the signal came."""

from __future__ import annotations

import contextlib

__all__ = ["interrupts_held", "terminate_as_interrupt", "interrupted", "interrupts_not_lost", "raise_dropped_interrupt"]


@contextlib.contextmanager
def interrupts_held():
    """Inside, a Ctrl-C (SIGINT) is recorded instead of raised; yields the list of the signals held,
    for the caller to act on after the block. For a program's imports: raised inside a library's
    import, a KeyboardInterrupt can be swallowed by the library (an ``except:`` around an optional
    import, and the command then runs to its end) or leave CPython to end the process by SIGINT.
    Only the main thread receives signals; elsewhere nothing is held, and neither where SIGINT is
    ignored (a script's background job) or handled outside Python."""
    import signal
    import threading

    held = []
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) in (signal.SIG_IGN, None):
        yield held
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        yield held
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def terminate_as_interrupt():
    """Inside, SIGTERM (``kill PID``, a batch system's time limit) is raised as a KeyboardInterrupt,
    so that the clean-up of a Ctrl-C runs for it too: staged outputs and ``.staging-*`` folders
    removed, lock files released. Only the main thread receives signals; elsewhere nothing is
    changed."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def raise_interrupt(signum, frame):
        raise KeyboardInterrupt("SIGTERM")

    previous = signal.signal(signal.SIGTERM, raise_interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def interrupted(exc) -> bool:
    """Whether ``exc`` is a Ctrl-C: a KeyboardInterrupt, or the SystemError that a numba kernel
    raises when the interrupt arrives while it runs ("... returned a result with an exception set"),
    however deep the chain: an interrupt inside numba's unpickling of a cached kernel comes as a
    SystemError caused by a SystemError caused by the KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        if not isinstance(exc, SystemError) and seen:
            return False
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


#: Ctrl-Cs that Python dropped inside :func:`interrupts_not_lost` (raised where they could not
#: propagate), waiting for :func:`raise_dropped_interrupt`
_DROPPED = []


# Hand-written: no library recovers the Ctrl-C that Python drops in a __del__ or GC callback.
@contextlib.contextmanager
def interrupts_not_lost():
    """Inside: a Ctrl-C is never dropped. Python raises the KeyboardInterrupt of a SIGINT in
    whatever code runs when it arrives; in a ``__del__`` method or a weakref or garbage-collection
    callback (an llvmlite object freed, a WeakValueDictionary entry removed) it cannot propagate,
    is printed as "Exception ignored in ..." and dropped, and a command went on to finish with
    exit status 0. Here such an interrupt is recorded instead (nothing printed) and raised by
    :func:`raise_dropped_interrupt` at the next point that checks: after each frame of the frame
    loop, before any output replaces an earlier one, and when the command returns. Only the main
    thread receives signals; elsewhere nothing is changed."""
    import sys
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = sys.unraisablehook

    def record(unraisable):
        if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
            _DROPPED.append(unraisable.exc_type)
            return
        previous(unraisable)

    _DROPPED.clear()
    sys.unraisablehook = record
    try:
        yield
    finally:
        sys.unraisablehook = previous
        _DROPPED.clear()


def raise_dropped_interrupt() -> None:
    """Raise the KeyboardInterrupt of a Ctrl-C that Python dropped inside
    :func:`interrupts_not_lost`; nothing if there was none."""
    if _DROPPED:
        _DROPPED.clear()
        raise KeyboardInterrupt
