"""``python -m granalytics`` and the ``granalytics`` console script (``pyproject.toml``).

The commands' modules take a second or two to import (pandas, numba, h5py); Ctrl-C is handled
from the first instant, also while they load: one line and exit status 130, never a traceback.
While they load, a Ctrl-C is held and acted on once they are loaded: raised inside a library's
import, it could be swallowed by the library (an ``except:`` around an optional import, and the
command then ran to its end) or leave the interpreter to end the process by SIGINT.
Once the command has finished (its outputs written whole, its table printed) the process still
takes half a second to shut down (numba, llvmlite and the modules are torn down); a Ctrl-C then
interrupts nothing, and it is ignored: the exit status is the command's, never a KeyboardInterrupt
"ignored" at exit with status 0 or a silent death by SIGINT.
"""

import contextlib
import signal
import sys
import threading


def main(argv=None) -> int:
    """Run the command line (:func:`granalytics.cli.main`); returns the exit status. Called
    without ``argv`` (the process's own command line: the console script, ``python -m``), a
    Ctrl-C after the command finished is ignored while the process exits."""
    loaded = sys.modules.get("granalytics.cli")
    if loaded is not None:  # a command run earlier in this process (tests) says nothing of this one
        loaded.finished = None
    try:
        with _interrupts_held() as held:
            from granalytics.cli import main as run
        if held:
            raise KeyboardInterrupt
        status = run(argv)
    except KeyboardInterrupt:
        done = getattr(sys.modules.get("granalytics.cli"), "finished", None)
        if done is None:  # before a command started (it handles its own): nothing was written
            print("granalytics: interrupted before any work; nothing was written", file=sys.stderr)
            return 130
        status = done  # as the finished command returned: it is done, its status stands
    if argv is None:
        _ignore_interrupts_from_now()
    return status


@contextlib.contextmanager
def _interrupts_held():
    """Inside, SIGINT is recorded instead of raised (main thread only); yields the list of the
    signals held."""
    held = []
    if threading.current_thread() is not threading.main_thread():
        yield held
        return
    previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        yield held
    finally:
        signal.signal(signal.SIGINT, previous)


def _ignore_interrupts_from_now() -> None:
    """Ignore SIGINT for the rest of the process (its shutdown): the command is done."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


if __name__ == "__main__":
    sys.exit(main())
